#!/usr/bin/env bash
# Multi-node rehearsal on one machine (#25 item 6). Two "nodes", each a
# network namespace with its own address (a veth pair, 10.77.0.1 and
# 10.77.0.2/24, inside namespaces this script makes and removes), its own
# host name (UTS namespace) and its own private /tmp and /dev/shm (a mount
# namespace with tmpfs over both), so nothing can pass through a shared /tmp
# or shared memory. What a cluster shares is mounted at the same path on
# both: the run directory's file system (this test's directory, at
# /srv/shared) and the installation (the tree, at /srv/root). Open MPI
# starts its daemon on the second node through a launch agent that enters
# that node's namespaces (where a cluster uses ssh or Slurm) and talks TCP
# only, over the veth pair (btl self,tcp; oob and btl on 10.77.0.0/24).
# Checks: the field quick config at 3 ranks over the two nodes (2 + 1) gives
# the golden digest; a run killed by taking one node down (SIGKILL of every
# process in it) mid-synthesis ends within 60 s with the job's ranks gone,
# and `geosynth resume` on the remaining node alone (2 ranks) gives the
# golden digest from the checkpoint written on the shared directory.
# Needs root with CAP_NET_ADMIN and CAP_SYS_ADMIN (ip netns, unshare
# --mount); elsewhere one "check skipped" line says so.
source "$GS_ROOT/tests/e2e/lib.bash"
cfg=configs/field/quick.ini
ref=$(golden field "$cfg")
n1=gsn1-$$ n2=gsn2-$$ va=gsva$$ vb=gsvb$$
for tool in ip unshare mount; do
  command -v $tool >/dev/null || { skipped "multi-node rehearsal: needs CAP_NET_ADMIN/ip netns ($tool is missing)"; finish; }
done
if ! why=$(ip netns add "$n1" 2>&1); then
  skipped "multi-node rehearsal: needs CAP_NET_ADMIN/ip netns (ip netns add: $why)"
  finish
fi
netns_pair "$n1" "$n2" "$va" "$vb" 10.77.0

# node.sh NS CMD...: CMD on node NS (its network, host name, private /tmp).
work=$PWD
cat >node.sh <<EOF
#!/bin/sh
ns=\$1; shift
exec ip netns exec "\$ns" unshare --mount --uts --propagation private sh -c '
  hostname "\$0" && mount -t tmpfs tmpfs /srv && mkdir /srv/shared /srv/root &&
  mount --bind "$work" /srv/shared && mount --bind "$GS_ROOT" /srv/root &&
  mount -t tmpfs tmpfs /tmp && mount -t tmpfs tmpfs /dev/shm && exec "\$@"' "\$ns" "\$@"
EOF
# agent.sh HOST COMMAND: Open MPI's launch agent (plm_rsh_agent) in place of
# ssh. It runs on node 1 (mpirun's node): back in this script's mount
# namespace first, so the new node gets mounts of its own, not node 1's.
command -v nsenter >/dev/null || { skipped "multi-node rehearsal: needs nsenter (util-linux)"; finish; }
cat >agent.sh <<EOF
#!/bin/sh
while [ "\${1#-}" != "\$1" ]; do shift; done
host=\$1; shift
exec nsenter --mount=/proc/$$/ns/mnt "$work/node.sh" "\$host" sh -c "\$*"
EOF
chmod +x node.sh agent.sh
why=$(./node.sh "$n2" sh -c 'hostname; find /tmp /dev/shm -mindepth 1 | wc -l; ip -4 -o addr show | grep -c "inet 10.77.0.2/24"; test -x /srv/root/bin/geosynth && test -f /srv/shared/node.sh && echo shared' 2>&1)
[[ $why == "$n2"$'\n0\n1\nshared' ]] || { bad "node namespaces: expected host name $n2, an empty /tmp and /dev/shm, the address 10.77.0.2 and /srv/root, /srv/shared; got: $why"; finish; }
ok "two nodes: network namespaces $n1 (10.77.0.1) and $n2 (10.77.0.2), own host names, private empty /tmp and /dev/shm"

export OMPI_MCA_btl=self,tcp OMPI_MCA_btl_tcp_if_include=10.77.0.0/24 OMPI_MCA_oob_tcp_if_include=10.77.0.0/24
export OMPI_MCA_plm_rsh_agent=/srv/shared/agent.sh OMPI_MCA_pml=ob1
unset OMPI_MCA_btl_vader_single_copy_mechanism
gs=/srv/root/bin/geosynth
# mpi NP HOSTS ARGS...: mpirun on node 1, ranks on HOSTS (host:slots,...).
mpi() {
  local np=$1 hosts=$2; shift 2
  timeout 300 ./node.sh "$n1" mpirun --display-map -np "$np" --host "$hosts" "$gs" "$@"
}

mpi 3 "$n1:2,$n2:1" field -c "/srv/root/$cfg" -o /srv/shared/run2 >two.out 2>two.err </dev/null
rc=$?
got=$(digest_of run2 2>/dev/null)
if [[ $rc -eq 0 && $got == "$ref" ]] && grep -q "Data for node: $n2.*Num procs: 1" two.out; then
  ok "field quick at 3 ranks on two nodes ($n1: 2, $n2: 1), TCP only: digest $got = golden (one node: the same)"
else
  bad "two-node run: exit $rc, digest '$got' (golden $ref): $(tail -c 800 two.err) $(grep 'Data for node' two.out)"
fi

# One node dies mid-run: every process in it is killed after the first checkpoint.
mpi 3 "$n1:1,$n2:2" field -c "/srv/root/$cfg" -o /srv/shared/run3 --set run.checkpoint_seconds=0 \
  --set run.checkpoint_every=200 >kill.out 2>kill.err </dev/null &
job=$!
for ((i = 0; i < 600; i++)); do [[ -f run3/checkpoint.h5 ]] && break; sleep 0.05; done
onnode2=$(for p in $(ip netns pids "$n2"); do tr '\0' ' ' <"/proc/$p/cmdline" 2>/dev/null; echo; done | grep -c "^$gs ")
t0=$SECONDS
kill -KILL $(ip netns pids "$n2") 2>/dev/null
wait $job
krc=$?
dt=$((SECONDS - t0))
left=$(ip netns pids "$n1" | wc -l)
if [[ -f run3/checkpoint.h5 && ! -f run3/summary.json && $onnode2 -eq 2 && $krc -ne 0 && $dt -le 60 && $left -eq 0 ]]; then
  ok "node $n2 (2 of the 3 ranks) killed after the first checkpoint: the job ended (exit $krc) within ${dt} s, no process left on $n1"
else
  bad "node kill: checkpoint $([[ -f run3/checkpoint.h5 ]] && echo yes || echo no), summary $([[ -f run3/summary.json ]] && echo yes || echo no), ranks seen on $n2: $onnode2, exit $krc after ${dt} s, processes left on $n1: $left; $(tail -c 600 kill.err)"
fi
timeout 300 ./node.sh "$n1" mpirun -np 2 --host "$n1:2" "$gs" resume /srv/shared/run3 >res.out 2>res.err </dev/null
rc=$?
got=$(digest_of run3 2>/dev/null)
[[ $rc -eq 0 && $got == "$ref" ]] && cat res.out res.err | grep -q "(resumed)" \
  && ok "resumed on the remaining node $n1 alone (2 ranks): digest $got = golden" \
  || bad "resume on $n1: exit $rc, digest '$got' (golden $ref): $(tail -c 800 res.err)"
finish
