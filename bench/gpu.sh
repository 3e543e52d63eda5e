#!/usr/bin/env bash
# A device check and its figures in one script, in under 10 minutes, for a machine with a
# GPU (or any OpenCL device): the device list and self-test, the `device` and
# `portability` test labels, `bench em` at K 8, 16 and 50, and the thesis-scale silk sweep
# (180 slices of 90 x 180, K in [1, 32]). CSVs named by the device go to bench/results/
# (gpu_<device>_em_k<K>.csv, gpu_<device>_sweep.csv, gpu_<device>_summary.csv).
#
#   [DEVICE=gpu] bench/gpu.sh [--quick] [--results DIR]
#
# DEVICE is a selector as for --device (default gpu). On NVIDIA, the ICD loader must find
# libnvidia-opencl.so.1: a folder holding an .icd file that names it, given as
# OCL_ICD_VENDORS, does. --quick: smaller sizes (a check of the script, as on oclgrind:
# DEVICE=oclgrind with oclgrind's .icd in OCL_ICD_VENDORS).
# Run from the repository root after scripts/setup (or with BIN=path/to/bsdfmix).
set -euo pipefail
cd "$(dirname "$0")/.."
bin=${BIN:-build/bsdfmix}
device=${DEVICE:-gpu}
results=bench/results
quick=0
while (($#)); do
  case "$1" in
    --quick) quick=1 ;;
    --results) results=$2; shift ;;
    -h|--help) sed -n '2,/^set -euo/p' "$0" | sed '$d' | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "gpu.sh: unknown argument '$1' (see --help)" >&2; exit 2 ;;
  esac
  shift
done
[ -x "$bin" ] || { echo "gpu.sh: $bin not found: run scripts/setup first" >&2; exit 2; }
mkdir -p "$results"
start=$(date +%s)
name=$("$bin" devices --device "$device" --check | awk -F': ' '/^self-test/ {sub(/^self-test \[[0-9]+\] /, "", $1); print $1; exit}')
[ -n "$name" ] || { echo "gpu.sh: no device matches '$device'" >&2; exit 2; }
tag=$(echo "$name" | tr 'A-Z' 'a-z' | sed 's/[^a-z0-9]\+/-/g; s/^-//; s/-$//' | cut -c1-40)
summary=$results/gpu_${tag}_summary.csv
echo "step,result,seconds,detail" > "$summary.tmp"
step() {  # step NAME COMMAND...: runs it, records ok/failed and the seconds
  local n=$1 t0 rc
  shift
  t0=$(date +%s.%N)
  set +e
  "$@" > "$results/.gpu_step.log" 2>&1
  rc=$?
  set -e
  local s
  s=$(awk -v a="$t0" -v b="$(date +%s.%N)" 'BEGIN { printf "%.1f", b - a }')
  local detail
  detail=$(tail -1 "$results/.gpu_step.log" | tr ',"' ';_' | cut -c1-200)
  echo "$n,$([ $rc -eq 0 ] && echo ok || echo "failed $rc"),$s,\"$detail\"" >> "$summary.tmp"
  echo "== $n: $([ $rc -eq 0 ] && echo ok || echo "FAILED ($rc)") in $s s: $detail"
}
echo "== device: $name ($tag)"
"$bin" devices | awk -v n="$name" 'index($0, "] " n) { p = 1 } p { print } p && /fitting kernels/ { exit }'
step devices_check "$bin" devices --check --device "$device"
if ((quick)); then
  step label_device env BSDFMIX_DEVICE="$device" ctest --test-dir build -L device -R "device_test|rng_test" --output-on-failure
else
  step label_device env BSDFMIX_DEVICE="$device" ctest --test-dir build -L device --output-on-failure
fi
if command -v oclgrind > /dev/null; then
  step label_portability ctest --test-dir build -L portability --output-on-failure
else
  echo "portability,skipped,0,\"oclgrind not installed\"" >> "$summary.tmp"
fi
ks="8 16 50"; slices=64; iterations=20
((quick)) && ks="8" && slices=1 && iterations=2
for k in $ks; do
  step "bench_em_k$k" "$bin" bench em --device "$device" --k "$k" --slices "$slices" --iterations $iterations --repeat 3 \
    --no-peers --csv "$results/gpu_${tag}_em_k$k.csv"
done
work=$(mktemp -d)
trap 'rm -rf "$work" "$results/.gpu_step.log"' EXIT
n_theta=180; n_ti=90; n_pi=180
((quick)) && n_theta=2 && n_ti=12 && n_pi=24
step generate "$bin" generate fiber -q --device "$device" --preset silk --theta-o $n_theta --theta-i $n_ti --phi-i $n_pi -o "$work/silk.h5"
cat > "$work/sweep.yaml" <<YAML
table: $work/silk.h5
fit:
  output: $work/mixture.h5
  report: $work/fit.csv
  search_report: $work/search.csv
  k_max: $( ((quick)) && echo 3 || echo 32)
YAML
((quick)) && printf '  restarts: 1\n  final_restarts: 1\n  iterations: 8\n  final_iterations: 8\n  refine_evaluations: 4\n' >> "$work/sweep.yaml"
step sweep "$bin" fit -q --device "$device" "$work/sweep.yaml"
if [ -f "$work/fit.csv" ]; then
  /usr/bin/python3 - "$work/fit.csv" "$results/gpu_${tag}_sweep.csv" "$name" <<'PY'
import csv, statistics, sys
rows = list(csv.DictReader(open(sys.argv[1])))
l1 = [float(r["l1_rel"]) for r in rows]
k = [int(r["k"]) for r in rows]
secs = sum(float(r["seconds"]) for r in rows)
with open(sys.argv[2], "w", newline="") as f:
    w = csv.writer(f)
    w.writerow(["device", "slices", "mean_k", "median_l1", "p90_l1", "fit_seconds_sum"])
    w.writerow([sys.argv[3], len(rows), round(statistics.mean(k), 3), round(statistics.median(l1), 5),
                round(sorted(l1)[int(0.9 * (len(l1) - 1))], 5), round(secs, 2)])
PY
fi
mv "$summary.tmp" "$summary"
echo "== gpu.sh: $(( $(date +%s) - start )) s; $summary"
! grep -q ',failed' "$summary"
