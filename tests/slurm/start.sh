#!/usr/bin/env bash
# Starts a private single-node Slurm cluster (munged + slurmctld + slurmd, all
# by hand, no systemd) for testing the job scripts in jobs/. Idempotent.
#   tests/slurm/start.sh DIR      -> writes DIR/slurm.conf, prints "export SLURM_CONF=DIR/slurm.conf"
#   tests/slurm/start.sh --stop DIR
# Needs root (the daemons run as root here) and the packages slurm-wlm and munge.
set -euo pipefail
if [[ "${1:-}" == "--stop" ]]; then
  dir=$2
  pids=()
  for p in slurmd slurmctld munged; do
    [[ -f "$dir/$p.pid" ]] && pid=$(cat "$dir/$p.pid") && kill "$pid" 2>/dev/null && pids+=("$pid")
  done
  # Wait (bounded) until they are gone, so that the caller may remove DIR.
  for _ in $(seq 100); do
    alive=0
    for pid in "${pids[@]}"; do kill -0 "$pid" 2>/dev/null && alive=1; done
    [[ $alive -eq 0 ]] && break
    sleep 0.1
  done
  exit 0
fi
dir=$(mkdir -p "$1" && cd "$1" && pwd)
host=$(hostname -s)
cpus=$(nproc)
mem=$(free -m | awk '/Mem/{print int($2*0.8)}')
mkdir -p "$dir/state" "$dir/spool" "$dir/log" "$dir/munge"
cat >"$dir/slurm.conf" <<CONF
ClusterName=geosynth-test
SlurmctldHost=$host
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
# A requeued job waits cred_expire + 1 s before it may start again (default 120).
AuthInfo=cred_expire=10
CredType=cred/munge
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/slurmctld.pid
SlurmdPidFile=$dir/slurmd.pid
SlurmctldLogFile=$dir/log/slurmctld.log
SlurmdLogFile=$dir/log/slurmd.log
SlurmctldPort=${GS_SLURMCTLD_PORT:-16817}
SlurmdPort=${GS_SLURMD_PORT:-16818}
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
MpiDefault=pmix
SwitchType=switch/none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
JobRequeue=1
KillWait=30
MinJobAge=300
NodeName=$host CPUs=$cpus RealMemory=$mem State=UNKNOWN
PartitionName=debug Nodes=$host Default=YES MaxTime=INFINITE State=UP OverSubscribe=FORCE:4
CONF
export SLURM_CONF=$dir/slurm.conf
# munge: a key of our own and a private socket
if [[ ! -f "$dir/munge/munge.key" ]]; then
  dd if=/dev/urandom of="$dir/munge/munge.key" bs=1024 count=1 status=none
  chmod 400 "$dir/munge/munge.key"
fi
if ! pgrep -x munged >/dev/null; then
  mkdir -p /run/munge /var/log/munge /var/lib/munge
  munged --force --key-file="$dir/munge/munge.key" --pid-file="$dir/munged.pid" \
    --log-file="$dir/log/munged.log" --seed-file="$dir/munge/seed" || munged --force
fi
pgrep -x slurmctld >/dev/null || slurmctld -i
pgrep -x slurmd >/dev/null || slurmd
for _ in $(seq 60); do
  if sinfo -h -o '%T' 2>/dev/null | grep -qE 'idle|mixed|allocated'; then
    echo "export SLURM_CONF=$SLURM_CONF"
    exit 0
  fi
  sleep 1
done
echo "slurm did not come up; logs in $dir/log" >&2
tail -20 "$dir/log/"*.log >&2
exit 1
