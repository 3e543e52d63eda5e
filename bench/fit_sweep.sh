#!/usr/bin/env bash
# The fitting-sweep targets: thesis-scale silk and polyester tables (180 theta_o slices of
# 90 x 180 cells) searched and fitted, each timed, with the error and compression summary
# that `bsdfmix fit` prints. Optionally (--full) a sweep of a full non-symmetric
# 90 x 180 x 90 x 180 table (K in [1, 16]) for BATCHES batches, with the rate and the projection;
# BATCHES = all runs it to completion.
#   bench/fit_sweep.sh [--full [BATCHES]]       (from the repository root, after scripts/setup)
set -euo pipefail
cd "$(dirname "$0")/.."
bin=build/bsdfmix
work=${BENCH_DIR:-out/bench_fit}
mkdir -p "$work"

for preset in silk polyester; do
  table=$work/$preset.h5
  [ -f "$table" ] || $bin generate fiber -q --preset $preset --theta-o 180 --theta-i 90 --phi-i 180 -o "$table"
  cat > "$work/$preset.yaml" <<YAML
table: $table
fit:
  output: $work/${preset}_mixture.h5
  report: $work/${preset}_fit.csv
  search_report: $work/${preset}_search.csv
  k_max: 32
YAML
  rm -rf "$work/${preset}_mixture.h5" "$work/${preset}_mixture.h5.parts"
  echo "== $preset: 180 slices of 90 x 180, K in [1, 32]"
  start=$(date +%s.%N)
  $bin fit -q "$work/$preset.yaml"
  end=$(date +%s.%N)
  awk -v s="$start" -v e="$end" 'BEGIN { printf "  command wall time %.1f s (target: under 120 s)\n", e - s }'
done

if [ "${1:-}" = "--full" ]; then
  batches=${2:-4}
  table=$work/silk_full.h5
  [ -f "$table" ] || $bin generate fiber -q --preset silk --no-symmetry --theta-o 90 --phi-o 180 --theta-i 90 --phi-i 180 -o "$table"
  cat > "$work/silk_full.yaml" <<YAML
table: $table
fit:
  output: $work/silk_full_mixture.h5
  report: $work/silk_full_fit.csv
  search_report: $work/silk_full_search.csv
  k_max: 16
YAML
  echo "== silk without symmetry: 90 x 180 slices of 90 x 180 (262 M cells), K in [1, 16], $batches batch(es) of 64 slices"
  before=$(ls "$work"/silk_full_mixture.h5.parts/batch_*.h5 2>/dev/null | wc -l)
  start=$(date +%s.%N)
  if [ "$batches" = all ]; then
    $bin fit -q "$work/silk_full.yaml"
    after=$((16200 / 64 + 1))
  else
    $bin fit -q --max-batches "$batches" "$work/silk_full.yaml"
    after=$(ls "$work"/silk_full_mixture.h5.parts/batch_*.h5 2>/dev/null | wc -l)
  fi
  end=$(date +%s.%N)
  done_slices=$((after - before))
  awk -v s="$start" -v e="$end" -v b="$done_slices" 'BEGIN {
    t = e - s; n = b * 64; if (n > 16200) n = 16200; r = n / t;
    printf "  %d slices in %.1f s: %.2f slices/s; projection for 16200 slices: %.1f h\n", n, t, r, 16200 / r / 3600 }'
fi
