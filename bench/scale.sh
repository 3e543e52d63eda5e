#!/usr/bin/env bash
# Scaling of the MPI task farm on this machine (docs/studies/scale_measured.md): one silk table fitted by
#   1rank_1core   one process pinned to core 0 (taskset), no mpirun: the baseline
#   2ranks_2cores mpirun -n 2, each rank bound to its own core
#   1proc_2cores  one process, no mpirun, both cores (PoCL's own threads): for context
#   2copies_2cores two independent 1-core fits of the same table at once, on cores 0 and 1:
#                 what 2 cores of this machine deliver for this work with no coordination
#                 at all (the ceiling of any 2-rank run; below 2x where the cores share
#                 an FMA unit or a power budget); its slices/s counts both copies
# Every rank's OpenCL device gets one compute unit (POCL_CPU_MAX_CU_NUM=1, a 1-core node),
# except 1proc_2cores. Each configuration runs RUNS times (default 3), interleaved, and
# the best fit time counts (the machine may be shared: best-of-N, and ratios from one
# run of this script). The fit time is the sweep's own `wall time` line (device set-up
# included, mpirun's launch not); the launch is recorded too.
# Writes bench/results/scale_<cpu>-<cores>c.csv (CSV=... to override): one row per
# configuration with slices/s, speed-up and efficiency against 1rank_1core, and for
# the 2-rank run the farm's traffic per batch against its compute per batch.
#   [RUNS=3] [THETA_O=180] [KMAX=16] [CSV=file] bench/scale.sh   (from the repository root, after scripts/setup)
set -euo pipefail
cd "$(dirname "$0")/.."
bin=${BIN:-build/bsdfmix}
work=${BENCH_DIR:-out/bench_scale}
runs=${RUNS:-3}
theta_o=${THETA_O:-180}
kmax=${KMAX:-16}
cpu=$(lscpu | sed -n 's/^Model name: *//p' | head -1)
cores=$(nproc)
slug=$(echo "$cpu" | tr 'A-Z' 'a-z' | sed 's/[^a-z0-9]\+/-/g; s/^-//; s/-$//')
csv=${CSV:-bench/results/scale_${slug}-${cores}c.csv}
mkdir -p "$work" "$(dirname "$csv")"
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1  # CI and containers run as root

table=$work/silk_${theta_o}.h5
[ -f "$table" ] || $bin generate fiber -q --preset silk --theta-o "$theta_o" --theta-i 45 --phi-i 90 -o "$table"
for c in 1rank_1core 2ranks_2cores 1proc_2cores copy0 copy1; do
  cat > "$work/$c.yaml" <<YAML
table: $table
fit:
  output: $work/${c}_mixture.h5
  report: $work/${c}_fit.csv
  search_report: $work/${c}_search.csv
  k_max: $kmax
  batch: 2
YAML
done

declare -A best launch
stats=$work/mpi_stats.csv
run_one() {  # $1 configuration; prints "fit_seconds launch_seconds"
  local c=$1 out err start end
  rm -rf "$work/${c}_mixture.h5" "$work/${c}_mixture.h5.parts"
  err=$work/$c.err
  start=$(date +%s.%N)
  case $c in
    1rank_1core) POCL_CPU_MAX_CU_NUM=1 POCL_MAX_PTHREAD_COUNT=1 taskset -c 0 $bin fit "$work/$c.yaml" > "$work/$c.out" 2> "$err" ;;
    2ranks_2cores) rm -f "$stats"
      mpirun -n 2 --bind-to core --map-by core --mca btl self,vader \
        -x POCL_CPU_MAX_CU_NUM=1 -x POCL_MAX_PTHREAD_COUNT=1 -x BSDFMIX_MPI_STATS="$stats" \
        $bin fit "$work/$c.yaml" > "$work/$c.out" 2> "$err" ;;
    1proc_2cores) $bin fit "$work/$c.yaml" > "$work/$c.out" 2> "$err" ;;
    2copies_2cores) rm -rf "$work"/copy?_mixture.h5 "$work"/copy?_mixture.h5.parts
      POCL_CPU_MAX_CU_NUM=1 POCL_MAX_PTHREAD_COUNT=1 taskset -c 0 $bin fit "$work/copy0.yaml" > "$work/copy0.out" 2> "$err" &
      POCL_CPU_MAX_CU_NUM=1 POCL_MAX_PTHREAD_COUNT=1 taskset -c 1 $bin fit "$work/copy1.yaml" > "$work/copy1.out" 2>> "$err"
      wait
      end=$(date +%s.%N)
      out=$(sed -n 's/^  wall time *\([0-9.]*\) s.*/\1/p' "$work/copy0.out" "$work/copy1.out" | sort -g | tail -1)
      # Two copies fit twice the slices: the time of one slice-set on 2 cores is half of it.
      echo "$(awk -v t="$out" 'BEGIN { printf "%.2f", t / 2 }') $(awk -v s="$start" -v e="$end" -v f="$out" 'BEGIN { printf "%.2f", e - s - f }')"
      return ;;
  esac
  end=$(date +%s.%N)
  out=$(sed -n 's/^  wall time *\([0-9.]*\) s.*/\1/p' "$work/$c.out")
  echo "$out $(awk -v s="$start" -v e="$end" -v f="$out" 'BEGIN { printf "%.2f", e - s - f }')"
}
for ((r = 0; r < runs; ++r)); do
  for c in 1rank_1core 2ranks_2cores 1proc_2cores 2copies_2cores; do
    read -r s l < <(run_one "$c")
    echo "run $((r + 1))/$runs $c: fit $s s (+ $l s launch)"
    if [ -z "${best[$c]:-}" ] || awk -v a="$s" -v b="${best[$c]}" 'BEGIN { exit !(a < b) }'; then
      best[$c]=$s
      launch[$c]=$l
      [ "$c" = 2ranks_2cores ] && cp "$stats" "$work/mpi_stats_best.csv"
    fi
  done
done
dump() {  # the fitted parameters of a mixture file, as hex of their bytes
  /usr/bin/python3 -c "import h5py,sys; f=h5py.File(sys.argv[1])['mixture']; print([f[k][()].tobytes().hex() for k in ('weights','means','covariances','k','l1_rel')])" "$1"
}
a=$(dump "$work/1rank_1core_mixture.h5") && b=$(dump "$work/2ranks_2cores_mixture.h5") || { echo "scale.sh: python3-h5py needed" >&2; exit 1; }
[ "$a" = "$b" ] && identical=yes || identical=no
slices=$(sed -n 's/^  slices *\([0-9]*\) fitted.*/\1/p' "$work/1rank_1core.out")
IFS=, read -r _ batches local task_b part_b compute commit < "$work/mpi_stats_best.csv"
remote=$((batches - local))
{
  echo "cpu,cores,config,ranks,slices,batches,fit_seconds,launch_seconds,slices_per_s,speedup,efficiency,bytes_out_per_remote_batch,bytes_back_per_remote_batch,compute_s_per_batch,commit_s_per_batch,bit_identical"
  for c in 1rank_1core 2ranks_2cores 1proc_2cores 2copies_2cores; do
    ranks=1; [ "$c" = 2ranks_2cores ] && ranks=2
    ncores=1; [ "$c" != 1rank_1core ] && ncores=2
    awk -v cpu="$cpu" -v cores="$cores" -v c="$c" -v n="$ranks" -v nc="$ncores" -v S="$slices" -v B="$batches" \
        -v t="${best[$c]}" -v l="${launch[$c]}" -v t1="${best[1rank_1core]}" -v rem="$remote" -v tb="$task_b" \
        -v pb="$part_b" -v cs="$compute" -v cm="$commit" -v id="$identical" 'BEGIN {
      sp = t1 / t
      mpi = (c == "2ranks_2cores")
      printf "\"%s\",%d,%s,%d,%d,%d,%.2f,%.2f,%.3f,%.3f,%.3f,%s,%s,%s,%s,%s\n", cpu, cores, c, n, S, B, t, l, S / t, sp, sp / nc,
        mpi ? sprintf("%.0f", tb / rem) : "", mpi ? sprintf("%.0f", pb / rem) : "", mpi ? sprintf("%.4f", cs / B) : "",
        mpi ? sprintf("%.5f", cm / B) : "", mpi ? id : ""
    }'
  done
} > "$csv"
column -s, -t "$csv"
awk -v a="${best[2ranks_2cores]}" -v c="${best[2copies_2cores]}" \
  'BEGIN { printf "2 ranks reach %.0f%% of what 2 independent copies get from these 2 cores\n", 100 * c / a }'
echo "wrote $csv"
