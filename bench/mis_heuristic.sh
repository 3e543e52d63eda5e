#!/usr/bin/env bash
# One-sample MIS: the balance heuristic (the default) against the power heuristic (beta 2)
# on the lighting study (configs/converge_light_<m>.yaml, every material, direction and
# scene), each estimator's variance at N = 65536 under both, one run each of the same
# binary, seeds and samples. Writes bench/results/mis_heuristic.csv (power's variance over
# balance's, from the relative MSE at N = 65536: above 1, balance is better). Needs the studies' outputs (their tables,
# mixtures and lighting mixtures): run `build/bsdfmix run configs/converge_light_<m>.yaml` first.
#   [CSV=file] bench/mis_heuristic.sh     (from the repository root)
set -euo pipefail
cd "$(dirname "$0")/.."
bin=build/bsdfmix
work=${BENCH_DIR:-out/bench_mis}
csv=${CSV:-bench/results/mis_heuristic.csv}
mkdir -p "$work" "$(dirname "$csv")"
for m in polyester cotton satin paper; do
  src=configs/converge_light_$m.yaml
  [ -f out/converge_light_$m/${m}_convergence.csv ] || { echo "mis_heuristic: run $bin run $src first" >&2; exit 1; }
  for h in balance power; do
    # the study's config with the heuristic set, its outputs in $work
    sed -e "s|^  csv: .*|  csv: $work/${m}_$h.csv\n  mis_heuristic: $h\n  light_mixture_dir: out/converge_light_$m/light_mixtures|" \
        -e "s|^  estimators: .*|  estimators: [us_tab, mis_light_cdf, mis_light_gmm, mis_product]|" \
        -e "/^charts:/,\$d" "$src" > "$work/${m}_$h.yaml"
    $bin converge -q "$work/${m}_$h.yaml"
  done
done
/usr/bin/python3 - "$work" "$csv" <<'PY'
import csv, sys, os
work, out = sys.argv[1], sys.argv[2]
rows = []
for m in ["polyester", "cotton", "satin", "paper"]:
    var = {}
    for h in ["balance", "power"]:
        for r in csv.DictReader(open(os.path.join(work, "%s_%s.csv" % (m, h)))):
            if int(r["samples"]) == 65536:
                var[(r["table"], r["theta_o"], r["scene"], r["estimator"], h)] = float(r["rel_rmse"]) ** 2
    for (t, th, sc, e, h), v in sorted(var.items()):
        if h != "balance" or e == "us_tab":
            continue
        p = var.get((t, th, sc, e, "power"))
        rows.append([t, th, sc, e, "%.6g" % v, "%.6g" % p, "%.4g" % (p / v if v > 0 else float("inf"))])
with open(out, "w", newline="") as f:
    w = csv.writer(f)
    w.writerow(["table", "theta_o", "scene", "estimator", "rel_mse_balance", "rel_mse_power", "power_over_balance"])
    w.writerows(rows)
print("mis_heuristic: wrote %s (%d rows)" % (out, len(rows)))
PY
