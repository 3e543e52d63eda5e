#!/usr/bin/env bash
# The fitting-sweep targets: thesis-scale silk and polyester tables (180 theta_o slices of
# 90 x 180 cells) searched and fitted, each run RUNS times (default 3; the best wall time
# is the row's figure), with the error and the sizes read back from the files by
# bench/fit_sweep_row.py into CSV (default bench/results/fit_sweep.csv; the CPU model
# and core count are columns). Optionally (--full) a sweep of a full non-symmetric
# 90 x 180 x 90 x 180 table (K in [1, 16]) for BATCHES batches, with the rate and the projection;
# BATCHES = all runs it to completion.
#   [RUNS=3] [CSV=file] bench/fit_sweep.sh [--full [BATCHES]]   (from the repository root, after scripts/setup)
set -euo pipefail
cd "$(dirname "$0")/.."
bin=build/bsdfmix
work=${BENCH_DIR:-out/bench_fit}
runs=${RUNS:-3}
csv=${CSV:-bench/results/fit_sweep.csv}
mkdir -p "$work" "$(dirname "$csv")"
rows=$(mktemp)
trap 'rm -f "$rows"' EXIT
bench/fit_sweep_row.py --header > "$rows"

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
  echo "== $preset: 180 slices of 90 x 180, K in [1, 32], best of $runs runs"
  times=""
  for ((r = 0; r < runs; ++r)); do
    rm -rf "$work/${preset}_mixture.h5" "$work/${preset}_mixture.h5.parts"
    start=$(date +%s.%N)
    if ((r == 0)); then $bin fit -q "$work/$preset.yaml"; else $bin fit -q "$work/$preset.yaml" > /dev/null; fi
    end=$(date +%s.%N)
    times="$times $(awk -v s="$start" -v e="$end" 'BEGIN { printf "%.2f", e - s }')"
  done
  best=$(echo $times | tr ' ' '\n' | sort -g | head -1)
  echo "  command wall time: best $best s of$times (target: under 120 s)"
  bench/fit_sweep_row.py "$table" "$work/${preset}_mixture.h5" 1 32 "$best" "${times# }" >> "$rows"
done
cp "$rows" "$csv.tmp" && mv "$csv.tmp" "$csv"
echo "wrote $csv"

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
