#!/usr/bin/env bash
# The datasheet study's throughput as a share of white noise's, measured the
# way a shared, noisy machine needs: N pairs of sweeps (default 21), the
# datasheet study (benches/datasheet-study.toml) and the same study without
# its datasheet sections run one after the other, each sweep's own
# throughput line read; prints both medians, their ratio and the median of
# the pairs' ratios.
#
#   benches/datasheet-ratio.sh [PAIRS] [TRIALS] [-- extra sweep arguments]
#   benches/datasheet-ratio.sh 21 60000
#   benches/datasheet-ratio.sh 9 60000 -- --threads 1
set -euo pipefail
cd "$(dirname "$0")/.."
pairs=${1:-21}
trials=${2:-60000}
shift $(( $# < 2 ? $# : 2 ))
[ "${1:-}" = "--" ] && shift
cargo build --release --quiet
bin=target/release/tricept-calib
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
# The white-noise twin: the same study less [sensors.encoder] and
# [sensors.scale] (each ends at the next blank line).
sed "s/^trials = .*/trials = $trials/" benches/datasheet-study.toml > "$work/sheet.toml"
awk '/^\[sensors\.(encoder|scale)\]/ {skip = 1} skip && /^$/ {skip = 0; next} !skip' \
  "$work/sheet.toml" > "$work/white.toml"
rate() {
  rm -rf "$work/out"
  "$bin" sweep --config "$1" --out "$work/out" --no-trials "${@:2}" 2>&1 |
    sed -n 's/.*= \([0-9]*\) calibrations\/s.*/\1/p'
}
for _ in $(seq "$pairs"); do
  echo "$(rate "$work/sheet.toml" "$@") $(rate "$work/white.toml" "$@")"
done > "$work/pairs"
median() { sort -g | awk '{v[NR] = $1} END {print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2}'; }
sheet=$(cut -d' ' -f1 "$work/pairs" | median)
white=$(cut -d' ' -f2 "$work/pairs" | median)
pair=$(awk '{print $1 / $2}' "$work/pairs" | median)
awk -v s="$sheet" -v w="$white" -v p="$pair" -v n="$pairs" 'BEGIN {
  printf "%d pairs: datasheet median %d, white noise median %d calibrations/s: %.1f %% by the medians, %.1f %% by the median pair\n",
    n, s, w, 100 * s / w, 100 * p
}'
