#!/usr/bin/python3
"""The channels in the L1 refinement (docs/studies/colour.md, "The channels in the refinement"),
variant by variant in one run: each fits the same tables with bench/rgb_stand_in.py under
its fit settings and is compared with the luminance alone (refine_rgb 0): the report's
luminance L1 median and p90, the RGB error less its negative part (median) and its ratio to
the luminance median (target 1.2), the mean K and the fit time, and importance sampling by
the mixture, the chi-square divergence of each slice from it (bench/mixture_chi_square.py:
the mean over the slices, and the median and p90 of the per-slice ratio to the luminance
alone's). Every variant keeps the components' colour (`rgb_copies: ~`, no colour copies:
docs/fitting.md, "Colour copies"), so that what is compared is what the refinement does.

    bench/rgb_refine.py [--bsdfmix build/bsdfmix] [--work out/rgb_refine]
                        [--csv bench/results/rgb_refine.csv]

The variants (refine_rgb, refine_kl; the channels' share a of the L1 error, the objective
taken over 1 - a, so that refine_kl / (1 - a) weighs the divergence against the luminance's
error):
  alone    0    5    the luminance alone (the code before the channels)
  default  0.5  5    the default
  third    1/3  5    a smaller share
  l1x2     0.5  2.5  the channels added at the luminance's weight, the divergence not
                     raised with them (the L1 part weighs twice as much against it)
  l1x3     2/3  5/3  the same at twice the channels' weight
"""
import argparse
import csv
import os
import statistics
import subprocess
import sys

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "bench"))
from mixture_chi_square import chi_squares  # noqa: E402
from rgb_stand_in import cpu_model  # noqa: E402

ALL = "satin,paper,sunflower,silk,cotton,polyester,wool"
SOME = "satin,paper,sunflower,polyester"  # the tables whose channels differ from their luminance
VARIANTS = [  # name, refine_rgb, refine_kl, tables
    ("alone", "0", "5", ALL),
    ("default", "0.5", "5", ALL),
    ("third", "0.333333", "5", SOME),
    ("l1x2", "0.5", "2.5", SOME),
    ("l1x3", "0.666667", "1.666667", SOME),
]


def report(path):
    with open(path) as f:
        rows = list(csv.DictReader(f))
    l1 = [float(r["l1_rel"]) for r in rows]
    rest = [float(r["rgb_l1_rel"]) - float(r["rgb_negative"]) for r in rows]
    return l1, rest, statistics.mean(int(r["k"]) for r in rows)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--bsdfmix", default=os.path.join(ROOT, "build", "bsdfmix"))
    ap.add_argument("--work", default=os.path.join(ROOT, "out", "rgb_refine"))
    ap.add_argument("--csv", default=os.path.join(ROOT, "bench", "results", "rgb_refine.csv"))
    args = ap.parse_args()
    script = os.path.join(ROOT, "bench", "rgb_stand_in.py")
    seconds = {}
    for name, share, kl, tables in VARIANTS:
        work = os.path.join(args.work, name)
        out_csv = os.path.join(work, "rgb_stand_in.csv")
        print(f"== {name}: refine_rgb {share}, refine_kl {kl}", flush=True)
        subprocess.run([sys.executable, script, "--bsdfmix", args.bsdfmix, "--work", work, "--tables", tables,
                        "--set", f"refine_rgb={share}", "--set", f"refine_kl={kl}", "--set", "rgb_copies=~",
                        "--csv", out_csv], check=True)
        with open(out_csv) as f:
            for r in csv.DictReader(f):
                seconds[(name, r["table"])] = float(r["fit_seconds"])
    rows = []
    for name, share, kl, tables in VARIANTS:
        for t in tables.split(","):
            base = os.path.join(args.work, "alone", t)
            here = os.path.join(args.work, name, t)
            l1, rest, mean_k = report(here + "_fit.csv")
            chi0 = chi_squares(base + ".h5", [base + "_mixture.h5"])[0][0]
            chi1 = chi_squares(here + ".h5", [here + "_mixture.h5"])[0][0]
            ratio = chi1 / chi0
            r = {"variant": name, "refine_rgb": share, "refine_kl": kl, "table": t, "mean_k": mean_k,
                 "l1_median": statistics.median(l1), "l1_p90": float(np.percentile(l1, 90)),
                 "rgb_less_negative_median": statistics.median(rest),
                 "ratio": statistics.median(rest) / statistics.median(l1), "fit_seconds": seconds[(name, t)],
                 "chi_mean": float(chi1.mean()), "chi_ratio_median": float(np.median(ratio)),
                 "chi_ratio_p90": float(np.percentile(ratio, 90))}
            print(f"{name:8s} {t:10s} L1 {100 * r['l1_median']:.2f}% (p90 {100 * r['l1_p90']:.2f}%), RGB less "
                  f"negative {100 * r['rgb_less_negative_median']:.2f}% ({r['ratio']:.3f}x), K {mean_k:.2f}, "
                  f"chi-square mean {r['chi_mean']:.4f}, ratio median {r['chi_ratio_median']:.3f} p90 "
                  f"{r['chi_ratio_p90']:.3f}", flush=True)
            rows.append(r)
    cpu = cpu_model()
    os.makedirs(os.path.dirname(args.csv), exist_ok=True)
    with open(args.csv, "w", newline="") as f:
        w = csv.writer(f)
        keys = list(rows[0].keys())
        w.writerow(keys + ["cpu_model", "logical_cpus"])
        for r in rows:
            w.writerow([f"{r[k]:.6g}" if isinstance(r[k], float) else r[k] for k in keys] + [cpu, os.cpu_count()])
    print(f"wrote {args.csv}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
