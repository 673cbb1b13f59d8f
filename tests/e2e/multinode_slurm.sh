#!/usr/bin/env bash
# Multi-node rehearsal under Slurm (#25 item 6, "a Slurm node per
# namespace"). Two "nodes" as in e2e/multinode: each a network namespace
# with its own address (10.78.0.1, 10.78.0.2 on a veth pair), host name and
# private /tmp and /dev/shm, a process holding the node's namespaces that
# every command of the node enters (nsenter). What a cluster shares is
# mounted at the same path on both: the run directory's file system (this
# test's directory, at /srv/shared) and the installation (the tree, at
# /srv/root). A private Slurm cluster on them: munged and slurmctld on node 1,
# one slurmd per node (`slurmd -N NODE`, NodeAddr = the node's address, its
# spool in the node's own /tmp), talking TCP between the addresses only;
# every daemon runs under a name of its own (gs-slurmctld, ...), so another
# test's `pgrep -x slurmctld` does not take it for its own. Checks:
#  1. sinfo shows both nodes idle.
#  2. jobs/field.sbatch, submitted with sbatch --nodes=2 --ntasks=3, runs
#     the field quick config with srun --mpi=pmix over both nodes (Open MPI
#     over TCP only): the golden digest (the one-node digest).
#  3. The same job, with every process of node 2 killed (slurmd, its
#     slurmstepd and ranks) after the first checkpoint: the job ends (not
#     COMPLETED) within 90 s, no process is left on node 1.
#  4. The run directory resumed by a one-node job on node 1 (the same
#     sbatch command: jobs/lib/job.sh resumes from the checkpoint) gives the
#     golden digest.
# Needs root with CAP_NET_ADMIN and CAP_SYS_ADMIN and slurm-wlm + munge;
# elsewhere one "check skipped" line says why.
source "$GS_ROOT/tests/e2e/lib.bash"
cfg=configs/field/quick.ini
ref=$(golden field "$cfg")
t0=$SECONDS
for tool in ip unshare nsenter mount slurmctld slurmd munged sbatch; do
  command -v $tool >/dev/null || { skipped "Slurm multi-node rehearsal: $tool is missing"; finish; }
done
id=$$
n1=gss1-$id n2=gss2-$id va=gssa$id vb=gssb$id
if ! why=$(ip netns add "$n1" 2>&1); then
  skipped "Slurm multi-node rehearsal: needs CAP_NET_ADMIN/ip netns (ip netns add: $why)"
  finish
fi
netns_pair "$n1" "$n2" "$va" "$vb" 10.78.0

# The node's namespaces live as long as its holder process (sleep).
work=$PWD
declare -A holder
for ns in "$n1" "$n2"; do
  # nsenter --net, not ip netns exec: that remounts /sys, and slurmd needs
  # the cgroup file systems under /sys/fs/cgroup
  nsenter --net="/run/netns/$ns" unshare --mount --uts --propagation private sh -c '
    hostname "$0" && mount -t tmpfs tmpfs /srv && mkdir /srv/shared /srv/root &&
    mount --bind "$1" /srv/shared && mount --bind "$2" /srv/root &&
    mount -t tmpfs tmpfs /tmp && mount -t tmpfs tmpfs /dev/shm && exec sleep 100000' \
    "$ns" "$work" "$GS_ROOT" </dev/null >/dev/null 2>&1 &
  holder[$ns]=$!
  disown
done
sleep 0.5
# on NS CMD...: CMD on node NS (its network, host name, mounts), from /srv/shared.
on() {
  local ns=$1; shift
  nsenter --target "${holder[$ns]}" --mount --uts --net sh -c 'cd /srv/shared && exec "$@"' sh "$@"
}
why=$(on "$n2" sh -c 'hostname; find /tmp /dev/shm -mindepth 1 | wc -l; ip -4 -o addr show | grep -c "inet 10.78.0.2/24"; test -x /srv/root/bin/geosynth && test -d /srv/shared && echo shared' 2>&1)
[[ $why == "$n2"$'\n0\n1\nshared' ]] || { bad "node namespaces: expected host name $n2, an empty /tmp and /dev/shm, the address 10.78.0.2 and /srv/root, /srv/shared; got: $why"; finish; }

# ---- a private Slurm cluster on the two nodes --------------------------------
S=/srv/shared/slurm
mkdir -p slurm/state slurm/log slurm/munge slurm/bin
for d in slurmctld slurmd munged; do ln -sf "$(command -v $d)" slurm/bin/gs-$d; done
dd if=/dev/urandom of=slurm/munge/munge.key bs=1024 count=1 status=none
chmod 755 slurm/munge && chmod 400 slurm/munge/munge.key
cpus=$(nproc)
cat >slurm/slurm.conf <<CONF
ClusterName=gs-multinode
SlurmctldHost=$n1(10.78.0.1)
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
AuthInfo=socket=$S/munge/munge.socket,cred_expire=10
CredType=cred/munge
StateSaveLocation=$S/state
SlurmdSpoolDir=/tmp/slurmd
SlurmctldPidFile=$S/slurmctld.pid
SlurmdPidFile=/tmp/slurmd.pid
SlurmctldLogFile=$S/log/slurmctld.log
SlurmdLogFile=$S/log/slurmd-%n.log
SlurmctldPort=16827
SlurmdPort=16828
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
MpiDefault=pmix
SwitchType=switch/none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
SlurmdTimeout=10
KillWait=5
MinJobAge=300
NodeName=$n1 NodeAddr=10.78.0.1 CPUs=$cpus State=UNKNOWN
NodeName=$n2 NodeAddr=10.78.0.2 CPUs=$cpus State=UNKNOWN
PartitionName=two Nodes=$n1,$n2 Default=YES MaxTime=INFINITE State=UP OverSubscribe=FORCE:4
CONF
export SLURM_CONF=$S/slurm.conf
on "$n1" "$S/bin/gs-munged" --force --socket="$S/munge/munge.socket" --key-file="$S/munge/munge.key" \
  --pid-file="$S/munged.pid" --log-file="$S/log/munged.log" --seed-file="$S/munge/seed" \
  2>>slurm/log/munged.log || { bad "munged did not start: $(tail -5 slurm/log/munged.log 2>/dev/null)"; finish; }
on "$n1" "$S/bin/gs-slurmctld" -i || { bad "slurmctld did not start: $(tail -5 slurm/log/slurmctld.log)"; finish; }
for ns in "$n1" "$n2"; do
  why=$(on "$ns" sh -c 'mkdir -p /tmp/slurmd && exec "$0" -N "$1"' "$S/bin/gs-slurmd" "$ns" 2>&1) \
    || { bad "slurmd $ns did not start: $why $(tail -5 "slurm/log/slurmd-$ns.log" 2>/dev/null)"; finish; }
done
for ((i = 0; i < 60; i++)); do
  st=$(on "$n1" sinfo -h -N -o '%N %T' 2>&1)
  [[ $(grep -c ' idle$' <<<"$st") -eq 2 ]] && break
  sleep 1
done
if [[ $(grep -c ' idle$' <<<"$st") -eq 2 ]]; then
  ok "Slurm on two nodes: slurmctld + slurmd on $n1 (10.78.0.1), slurmd on $n2 (10.78.0.2): $(tr '\n' ' ' <<<"$st")"
else
  bad "Slurm nodes not idle after 60 s: $st; slurmctld: $(tail -5 slurm/log/slurmctld.log); slurmd $n2: $(tail -5 slurm/log/slurmd-$n2.log 2>/dev/null)"
  finish
fi

export OMPI_MCA_btl=self,tcp OMPI_MCA_btl_tcp_if_include=10.78.0.0/24 OMPI_MCA_oob_tcp_if_include=10.78.0.0/24
export OMPI_MCA_pml=ob1 GEOSYNTH=/srv/root/bin/geosynth
unset OMPI_MCA_btl_vader_single_copy_mechanism
job_state() { on "$n1" scontrol show job "$1" 2>/dev/null | grep -o 'JobState=[A-Z_]*' | head -1 | cut -d= -f2; }
# wait_end JOB SECONDS: until JOB has ended (sets $state).
wait_end() {
  local i
  for ((i = 0; i < $2 * 2; i++)); do
    state=$(job_state "$1")
    [[ $state == COMPLETED || $state == FAILED || $state == CANCELLED || $state == TIMEOUT || $state == NODE_FAIL ]] && return 0
    sleep 0.5
  done
  return 1
}
# submit RUN SBATCH-ARGS...: jobs/field.sbatch with the quick config into
# /srv/shared/RUN, with the --set in ${sets[@]}.
sets=()
submit() {
  local run=$1; shift
  on "$n1" sbatch --parsable --output="/srv/shared/sbatch-%j.out" "$@" /srv/root/jobs/field.sbatch \
    "/srv/root/$cfg" "/srv/shared/$run" "${sets[@]}"
}

# 2. one job over both nodes
job=$(submit two --nodes=2 --ntasks=3)
wait_end "$job" 120 || bad "job $job still '$state' after 120 s"
log=$(cat two/slurm-"$job".out 2>/dev/null)
got=$(digest_of two 2>/dev/null)
nodes=$(on "$n1" scontrol show job "$job" 2>/dev/null | grep -o ' NodeList=[^ ]*' | head -1)
if [[ $state == COMPLETED && $got == "$ref" && $nodes == *gss1-$id* && $nodes == *gss2-$id* ]] && grep -q "srun --mpi=pmix" <<<"$log"; then
  ok "sbatch --nodes=2 --ntasks=3 jobs/field.sbatch: job $job $nodes, srun --mpi=pmix, TCP only: digest $got = golden (one node: the same)"
else
  bad "two-node job $job: '$state', digest '$got' (golden $ref): $(tail -c 800 <<<"$log") $(tail -c 400 sbatch-$job.out 2>/dev/null)"
fi

# 3. node 2 dies mid-run (--no-requeue: Slurm would requeue the job, which
# asks for two nodes, and it would wait for node 2)
# (a checkpoint every 200 blocks: the first comes after 0.5 s; over the two
# nodes the run then slows to about 10 s per checkpoint, README)
sets=(--set run.checkpoint_seconds=0 --set run.checkpoint_every=200)
job=$(submit kill --nodes=2 --ntasks=3 --no-requeue)
for ((i = 0; i < 600; i++)); do [[ -f kill/checkpoint.h5 ]] && break; sleep 0.1; done
ranks() { for p in $(ip netns pids "$1"); do { tr '\0' ' ' <"/proc/$p/cmdline"; } 2>/dev/null; echo; done | grep -c "^/srv/root/bin/geosynth "; }
onnode1=$(ranks "$n1") onnode2=$(ranks "$n2")
t1=$SECONDS
kill -KILL $(ip netns pids "$n2") 2>/dev/null
for ((i = 0; i < 600; i++)); do [[ $(ranks "$n1") -eq 0 ]] && break; sleep 0.1; done
dranks=$((SECONDS - t1)) left=$(ranks "$n1")
wait_end "$job" 90
djob=$((SECONDS - t1))
klog=$(cat kill/slurm-"$job".out 2>/dev/null)
if [[ -f kill/checkpoint.h5 && ! -f kill/summary.json && $onnode1 -eq 2 && $onnode2 -eq 1 && $left -eq 0 && $state != COMPLETED && $state != RUNNING && $state != PENDING ]]; then
  ok "every process of $n2 (its rank, slurmd and slurmstepd) killed after the first checkpoint: the 2 ranks on $n1 ended within ${dranks} s, job $job '$state' within ${djob} s"
else
  bad "node kill: checkpoint $([[ -f kill/checkpoint.h5 ]] && echo yes || echo no), summary $([[ -f kill/summary.json ]] && echo yes || echo no), ranks seen on $n1 / $n2: $onnode1 / $onnode2, ranks left on $n1 after ${dranks} s: $left, job '$state' after ${djob} s; $(tail -c 800 <<<"$klog")"
fi

# 4. resumed by a one-node job on the remaining node
job=$(submit kill --nodes=1 --ntasks=2 -w "$n1")
wait_end "$job" 120 || bad "resume job $job still '$state' after 120 s"
rlog=$(cat kill/slurm-"$job".out 2>/dev/null)
got=$(digest_of kill 2>/dev/null)
if [[ $state == COMPLETED && $got == "$ref" ]] && grep -q "resuming /srv/shared/kill" <<<"$rlog"; then
  ok "resumed by job $job on $n1 alone (2 ranks, the same sbatch command): digest $got = golden"
else
  bad "resume job $job on $n1: '$state', digest '$got' (golden $ref): $(tail -c 800 <<<"$rlog")"
fi
ok "Slurm multi-node rehearsal took $((SECONDS - t0)) s"
finish
