#!/usr/bin/env bash
# One-node Slurm cluster on localhost: installs Debian's slurm-wlm and munge when
# missing, starts munged, slurmctld and slurmd with a throw-away configuration, submits the job
# array that `motionlab slurm` generates for a 4-shard sweep plus its afterok merge job, waits,
# and checks the merged tables equal a plain local run. Every daemon it starts is stopped on
# exit. Exit 0 = pass, 1 = fail, 77 = skipped (not root / no apt).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
repo=$(cd "$here/../.." && pwd)
motionlab=${MOTIONLAB:-${CARGO_TARGET_DIR:-$HOME/.cache/motionlab-target}/debug/motionlab}
deadline=$((SECONDS + 540))

if [ "$(id -u)" != 0 ]; then echo "slurm test SKIPPED: needs root to start slurmd"; exit 77; fi
if ! command -v slurmctld >/dev/null || ! command -v munged >/dev/null; then
  if ! command -v apt-get >/dev/null; then echo "slurm test SKIPPED: no apt-get to install slurm-wlm"; exit 77; fi
  echo "installing slurm-wlm and munge…"
  DEBIAN_FRONTEND=noninteractive apt-get install -y -q slurm-wlm munge >/tmp/mlab-slurm-apt.log 2>&1 \
    || { tail -20 /tmp/mlab-slurm-apt.log; echo "slurm test FAILED: apt-get install"; exit 1; }
fi

work=$(mktemp -d /tmp/mlab-slurm.XXXXXX)
chmod 755 "$work"
started_munge=0
cleanup() {
  for pid in "$work/slurmd.pid" "$work/slurmctld.pid"; do
    [ -f "$pid" ] && kill "$(cat "$pid")" 2>/dev/null || true
  done
  if [ "$started_munge" = 1 ] && [ -f /run/munge/munged.pid ]; then kill "$(cat /run/munge/munged.pid)" 2>/dev/null || true; fi
  sleep 1
  for pid in "$work/slurmd.pid" "$work/slurmctld.pid"; do
    [ -f "$pid" ] && kill -9 "$(cat "$pid")" 2>/dev/null || true
  done
}
trap cleanup EXIT
trap "exit 1" INT TERM

# munge: a key, its runtime folder owned by munge, the daemon as the munge user.
[ -f /etc/munge/munge.key ] || mungekey -c -k /etc/munge/munge.key
chown munge:munge /etc/munge/munge.key; chmod 400 /etc/munge/munge.key
mkdir -p /run/munge /var/log/munge /var/lib/munge; chown munge:munge /run/munge /var/log/munge /var/lib/munge
if ! pgrep -x munged >/dev/null; then
  runuser -u munge -- munged
  started_munge=1
fi

host=$(hostname -s)
mem=$(awk '/MemTotal/ { printf "%d", $2 / 1024 * 0.8 }' /proc/meminfo)
mkdir -p "$work/state" "$work/spool"
cat >"$work/slurm.conf" <<CONF
ClusterName=motionlab-test
SlurmctldHost=$host
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
SchedulerType=sched/backfill
MpiDefault=none
ReturnToService=2
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
StateSaveLocation=$work/state
SlurmdSpoolDir=$work/spool
SlurmctldPidFile=$work/slurmctld.pid
SlurmdPidFile=$work/slurmd.pid
SlurmctldLogFile=$work/slurmctld.log
SlurmdLogFile=$work/slurmd.log
NodeName=$host CPUs=$(nproc) RealMemory=$mem State=UNKNOWN
PartitionName=debug Nodes=ALL Default=YES MaxTime=INFINITE State=UP
CONF
export SLURM_CONF="$work/slurm.conf"
slurmctld -f "$SLURM_CONF"
slurmd -f "$SLURM_CONF"
for _ in $(seq 60); do
  sinfo -h -o %T 2>/dev/null | grep -qE '^(idle|mixed|allocated)' && break
  sleep 1
done
sinfo

run_dir="$work/run"
"$motionlab" slurm "$here/sweep.toml" --shards 4 --run-dir "$run_dir" --time 00:05:00 --submit | tee "$work/submit.txt"
merge_id=$(sed -n 's/.*merge job \([0-9]*\).*/\1/p' "$work/submit.txt")
[ -n "$merge_id" ] || { echo "slurm test FAILED: no merge job id"; exit 1; }
while squeue -h | grep -q .; do
  if squeue -h -o %r | grep -q DependencyNeverSatisfied; then
    echo "slurm test FAILED: a shard task failed, so the merge job can never start"; cat "$run_dir"/slurm/*.log || true; exit 1
  fi
  if [ $SECONDS -gt $deadline ]; then echo "slurm test FAILED: jobs still queued after 9 minutes"; squeue; exit 1; fi
  sleep 2
done
cat "$run_dir"/slurm/*.log || true
[ -f "$run_dir/provenance.json" ] || { echo "slurm test FAILED: the merge job wrote no provenance"; tail -30 "$work/slurmctld.log"; exit 1; }

"$motionlab" run "$here/sweep.toml" --quiet --reports "$work/local" | tee "$work/local.txt"
local_run=$(sed -n 's/^\(.*\): [0-9]* item(s).*/\1/p' "$work/local.txt")
status=0
n=0
for f in "$local_run"/tables/*.csv; do
  n=$((n + 1))
  cmp -s "$f" "$run_dir/tables/$(basename "$f")" || { echo "differs: $(basename "$f")"; status=1; }
done
[ "$n" -gt 0 ] || { echo "slurm test FAILED: the local run wrote no table"; exit 1; }
if [ $status = 0 ]; then
  echo "slurm test: OK — 4 array tasks + afterok merge; $n merged table(s) equal the local run"
else
  echo "slurm test FAILED: merged tables differ from the local run"
fi
exit $status
