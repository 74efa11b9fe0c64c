#!/usr/bin/env bash
# Submit a sharded tricept-calib sweep to Slurm: an array job of N shards and
# a merge job that runs when every shard has succeeded (--dependency=afterok).
#
#   scripts/slurm-sweep.sh --config study.toml --shards 16 --out results/study \
#       [--bin PATH] [--cpus 4] [--time 01:00:00] [--mem 2G] [--partition P] \
#       [--seed S] [--trials N] [--no-trials]
#
# Shard K writes OUT/shards/K (partial result, trials.csv, log); the merge job
# writes the usual sweep outputs to OUT. Shards run with --resume, so
# resubmitting the same command after a failure reruns only unfinished shards.
# Prints the two job ids ("ARRAY_ID MERGE_ID") on stdout.
set -euo pipefail

usage() { sed -n '2,14p' "$0" | sed 's/^# \{0,1\}//' >&2; exit 2; }

config="" shards="" out="" bin="" cpus=2 time_limit="01:00:00" mem="2G" partition="" extra=()
while [ $# -gt 0 ]; do
  case "$1" in
    --config) config="$2"; shift 2 ;;
    --shards) shards="$2"; shift 2 ;;
    --out) out="$2"; shift 2 ;;
    --bin) bin="$2"; shift 2 ;;
    --cpus) cpus="$2"; shift 2 ;;
    --time) time_limit="$2"; shift 2 ;;
    --mem) mem="$2"; shift 2 ;;
    --partition) partition="$2"; shift 2 ;;
    --seed|--trials) extra+=("$1" "$2"); shift 2 ;;
    --no-trials) extra+=("$1"); shift ;;
    -h|--help) usage ;;
    *) echo "slurm-sweep.sh: unknown argument '$1'" >&2; usage ;;
  esac
done
[ -n "$config" ] && [ -n "$shards" ] && [ -n "$out" ] || usage
case "$shards" in ''|*[!0-9]*|0) echo "slurm-sweep.sh: --shards must be a positive integer" >&2; exit 2 ;; esac
[ -f "$config" ] || { echo "slurm-sweep.sh: config $config does not exist" >&2; exit 2; }
if [ -z "$bin" ]; then
  bin=$(command -v tricept-calib || true)
  [ -n "$bin" ] || bin="$(cd "$(dirname "$0")/.." && pwd)/target/release/tricept-calib"
fi
[ -x "$bin" ] || { echo "slurm-sweep.sh: no tricept-calib binary at $bin (build with cargo build --release or pass --bin)" >&2; exit 2; }
command -v sbatch >/dev/null || { echo "slurm-sweep.sh: sbatch not found (is Slurm installed and SLURM_CONF set?)" >&2; exit 2; }

abs() { case "$1" in /*) echo "$1" ;; *) echo "$PWD/$1" ;; esac; }
config=$(abs "$config"); out=$(abs "$out"); bin=$(abs "$bin")
mkdir -p "$out/shards" "$out/logs"
part=(); [ -n "$partition" ] && part=(--partition "$partition")
q() { [ $# -eq 0 ] || printf '%q ' "$@"; }

array_id=$(sbatch --parsable "${part[@]}" \
  --job-name=tricept-sweep --array="1-$shards" \
  --cpus-per-task="$cpus" --mem="$mem" --time="$time_limit" \
  --output="$out/logs/shard-%a.out" \
  --wrap="$(q "$bin" sweep --config "$config") --shard \$SLURM_ARRAY_TASK_ID/$shards --threads $cpus --resume $(q "${extra[@]}") --out $(printf %q "$out/shards")/\$SLURM_ARRAY_TASK_ID")
array_id=${array_id%%;*}

dirs=()
for k in $(seq 1 "$shards"); do dirs+=("$out/shards/$k"); done
merge_id=$(sbatch --parsable "${part[@]}" \
  --job-name=tricept-merge --dependency="afterok:$array_id" \
  --cpus-per-task=1 --mem="$mem" --time="$time_limit" \
  --output="$out/logs/merge.out" \
  --wrap="$(q "$bin" merge "${dirs[@]}" --out "$out")")
merge_id=${merge_id%%;*}
echo "$array_id $merge_id"
