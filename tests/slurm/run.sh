#!/usr/bin/env bash
# Integration test: a one-node Slurm cluster (munge, slurmctld, slurmd as
# background processes under a temporary folder), a 4-shard sweep submitted
# through scripts/slurm-sweep.sh, and the merged summary compared byte for
# byte with a single-process run. Every daemon it starts is stopped by PID,
# also when the test fails.
#   tests/slurm/run.sh [path/to/tricept-calib]
set -euo pipefail
cd "$(dirname "$0")/../.."
root=$PWD
bin=$(cd "$(dirname "${1:-target/debug/tricept-calib}")" && pwd)/$(basename "${1:-target/debug/tricept-calib}")
[ -x "$bin" ] || { echo "slurm test: no binary at $bin" >&2; exit 1; }

if ! command -v slurmctld >/dev/null || ! command -v munged >/dev/null || ! command -v sbatch >/dev/null; then
  echo "slurm test: installing Slurm and munge from Debian's packages"
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq >/dev/null
  apt-get install -y -qq --no-install-recommends slurmctld slurmd slurm-client munge >/dev/null
fi

T=$(mktemp -d /tmp/tricept-slurm.XXXXXX)
chmod 755 "$T"
stop() {
  local rc=$?
  export SLURM_CONF="$T/slurm.conf"
  command -v scancel >/dev/null && scancel --user=root >/dev/null 2>&1 || true
  for pidfile in "$T/slurmd.pid" "$T/slurmctld.pid" "$T/munge/munged.pid"; do
    [ -s "$pidfile" ] || continue
    pid=$(cat "$pidfile")
    name=$(cat "/proc/$pid/comm" 2>/dev/null || true)
    case "$name" in slurmd|slurmctld|munged) kill -TERM "$pid" 2>/dev/null || true ;; esac
  done
  for _ in $(seq 1 50); do
    alive=0
    for pidfile in "$T/slurmd.pid" "$T/slurmctld.pid" "$T/munge/munged.pid"; do
      [ -s "$pidfile" ] && kill -0 "$(cat "$pidfile")" 2>/dev/null && [ "$(cat /proc/"$(cat "$pidfile")"/stat 2>/dev/null | awk '{print $3}')" != "Z" ] && alive=1
    done
    [ $alive = 0 ] && break
    sleep 0.1
  done
  if [ $rc -ne 0 ]; then
    echo "slurm test FAILED (rc $rc); logs:" >&2
    for f in "$T"/*.log "$T"/out/logs/*.out; do
      [ -f "$f" ] && { echo "== $f" >&2; tail -n 15 "$f" >&2; }
    done
  fi
  [ -n "${KEEP_SLURM_TMP:-}" ] || rm -rf "$T"
  exit $rc
}
trap stop EXIT

# munge
mkdir -p "$T/munge"
chmod 755 "$T/munge"
mungekey -c -k "$T/munge/munge.key" >/dev/null 2>&1 || dd if=/dev/urandom of="$T/munge/munge.key" bs=1024 count=1 2>/dev/null
chmod 600 "$T/munge/munge.key"
munged --key-file="$T/munge/munge.key" --socket="$T/munge/munge.socket.2" \
  --pid-file="$T/munge/munged.pid" --log-file="$T/munge/munged.log" --seed-file="$T/munge/munged.seed" --force

# slurm.conf
host=$(hostname -s)
node=$(slurmd -C | head -n 1 | sed "s/^NodeName=[^ ]*/NodeName=$host/")
mkdir -p "$T/state" "$T/spool"
cat > "$T/slurm.conf" <<CONF
ClusterName=tricept
SlurmctldHost=$host(127.0.0.1)
SlurmUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$T/munge/munge.socket.2
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
SchedulerParameters=batch_sched_delay=0
MpiDefault=none
ReturnToService=2
StateSaveLocation=$T/state
SlurmdSpoolDir=$T/spool
SlurmctldPidFile=$T/slurmctld.pid
SlurmdPidFile=$T/slurmd.pid
SlurmctldLogFile=$T/slurmctld.log
SlurmdLogFile=$T/slurmd.log
SlurmctldPort=16817
SlurmdPort=16818
MinJobAge=600
$node NodeAddr=127.0.0.1 State=UNKNOWN
PartitionName=debug Nodes=ALL Default=YES MaxTime=INFINITE State=UP
CONF
export SLURM_CONF="$T/slurm.conf"
slurmctld -c -f "$SLURM_CONF"
slurmd -f "$SLURM_CONF" -N "$host"
for _ in $(seq 1 100); do
  scontrol ping >/dev/null 2>&1 && sinfo -h -o %T 2>/dev/null | grep -qE 'idle|mix|alloc' && break
  sleep 0.2
done
sinfo -h -o '%P %T %c' | grep -qE 'idle|mix|alloc' || { echo "slurm test: the node did not come up" >&2; exit 1; }

# The study: single process, then 4 shards through the script.
cat > "$T/study.toml" <<'TOML'
[sweep]
encoder_arcsec = [1.0, 4.0]
scale_um = [0.5, 2.0]
methods = ["ols", "wls"]
trials = 36000
seed = 7
TOML
"$bin" sweep --config "$T/study.toml" --out "$T/single" >/dev/null
read -r array_id merge_id < <("$root/scripts/slurm-sweep.sh" --config "$T/study.toml" --shards 4 --out "$T/out" --bin "$bin" --cpus 1 --mem 500M --time 00:10:00)
echo "slurm test: submitted array $array_id and merge $merge_id"
started=$(date +%s)
while squeue -h -j "$array_id,$merge_id" 2>/dev/null | grep -q .; do
  [ $(( $(date +%s) - started )) -lt 300 ] || { echo "slurm test: jobs did not finish in 300 s" >&2; squeue >&2; exit 1; }
  if squeue -h -j "$merge_id" -o %r 2>/dev/null | grep -q DependencyNeverSatisfied; then
    echo "slurm test: a shard failed, the merge can never run" >&2
    exit 1
  fi
  sleep 0.5
done
state=$(scontrol -o show job "$merge_id" | grep -o 'JobState=[A-Z]*' | cut -d= -f2)
exit_code=$(scontrol -o show job "$merge_id" | grep -o ' ExitCode=[0-9:]*' | cut -d= -f2)
[ "$state" = COMPLETED ] && [ "$exit_code" = "0:0" ] || { echo "slurm test: merge job $state (exit $exit_code)" >&2; exit 1; }
cmp "$T/single/summary.csv" "$T/out/summary.csv"
cmp "$T/single/trials.csv" "$T/out/trials.csv"
n=$(grep -c '"[0-9]/4:' "$T/out/manifest.json")
[ "$n" = 4 ] || { echo "slurm test: manifest lists $n shards" >&2; exit 1; }
echo "slurm test: 4 shards merged; summary.csv and trials.csv equal the single-process run byte for byte (wall $(( $(date +%s) - started )) s)"
echo "1 passed, 0 failed"
