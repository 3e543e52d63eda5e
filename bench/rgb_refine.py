#!/usr/bin/python3
"""The L1 refinement's settings, variant by variant in one run: each variant fits the same
tables with bench/rgb_stand_in.py under its fit settings and is compared with a baseline
variant. Two sets of variants:

- `--variants rgb` (the default): the channels in the L1 refinement (docs/fitting.md, "The
  channels move the Gaussians"), against the luminance alone (refine_rgb 0);
- `--variants kl`: the divergence's weight `refine_kl` and the evaluations (docs/fitting.md,
  "The L1 refinement"), on satin and sunflower, against EM's fits (refine none); its CSV
  is bench/results/refine_kl.csv.

Per variant and table: the report's
luminance L1 median and p90, the RGB error less its negative part (median) and its ratio to
the luminance median (target 1.2), the mean K and the fit time, and importance sampling by
the mixture, the chi-square divergence of each slice from it (bench/mixture_chi_square.py:
the mean over the slices, and the median and p90 of the per-slice ratio to the baseline's).

    bench/rgb_refine.py [--variants rgb|kl] [--bsdfmix build/bsdfmix] [--work out/rgb_refine]
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

The kl variants (refine, refine_kl, refine_evaluations; refine_rgb its default 0.5):
  em        none                EM's fits, the baseline
  kl0_60    l1   0    60        the L1 error alone
  kl3_60, kl5_60, kl10_60       the divergence at 3, 5 and 10 times, 60 evaluations
  kl5_120   l1   5    120
  default   l1   5    150       the defaults
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
VARIANTS = {  # name, fit settings, tables; the first is the baseline
    "rgb": [
        ("alone", {"refine_rgb": "0", "refine_kl": "5"}, ALL),
        ("default", {"refine_rgb": "0.5", "refine_kl": "5"}, ALL),
        ("third", {"refine_rgb": "0.333333", "refine_kl": "5"}, SOME),
        ("l1x2", {"refine_rgb": "0.5", "refine_kl": "2.5"}, SOME),
        ("l1x3", {"refine_rgb": "0.666667", "refine_kl": "1.666667"}, SOME),
    ],
    "kl": [("em", {"refine": "none"}, "satin,sunflower")] + [
        ("kl%s_%s" % (kl, ev), {"refine_kl": kl, "refine_evaluations": ev}, "satin,sunflower")
        for kl, ev in (("0", "60"), ("3", "60"), ("5", "60"), ("10", "60"), ("5", "120"))] + [
        ("default", {}, "satin,sunflower")],
}


def report(path):
    with open(path) as f:
        rows = list(csv.DictReader(f))
    l1 = [float(r["l1_rel"]) for r in rows]
    rest = [float(r["rgb_l1_rel"]) - float(r["rgb_negative"]) for r in rows]
    return l1, rest, statistics.mean(int(r["k"]) for r in rows)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--variants", choices=sorted(VARIANTS), default="rgb")
    ap.add_argument("--bsdfmix", default=os.path.join(ROOT, "build", "bsdfmix"))
    ap.add_argument("--work", default=None, help="out/rgb_refine (rgb) or out/refine_kl (kl)")
    ap.add_argument("--csv", default=None, help="bench/results/rgb_refine.csv (rgb) or refine_kl.csv (kl)")
    args = ap.parse_args()
    name_of = {"rgb": "rgb_refine", "kl": "refine_kl"}[args.variants]
    args.work = args.work or os.path.join(ROOT, "out", name_of)
    args.csv = args.csv or os.path.join(ROOT, "bench", "results", name_of + ".csv")
    variants = VARIANTS[args.variants]
    baseline = variants[0][0]
    script = os.path.join(ROOT, "bench", "rgb_stand_in.py")
    seconds = {}
    for name, settings, tables in variants:
        work = os.path.join(args.work, name)
        out_csv = os.path.join(work, "rgb_stand_in.csv")
        print(f"== {name}: " + (", ".join(f"{k} {v}" for k, v in settings.items()) or "the defaults"), flush=True)
        sets = [a for k, v in settings.items() for a in ("--set", f"{k}={v}")]
        subprocess.run([sys.executable, script, "--bsdfmix", args.bsdfmix, "--work", work, "--tables", tables,
                        *sets, "--csv", out_csv], check=True)
        with open(out_csv) as f:
            for r in csv.DictReader(f):
                seconds[(name, r["table"])] = float(r["fit_seconds"])
    rows = []
    for name, settings, tables in variants:
        for t in tables.split(","):
            base = os.path.join(args.work, baseline, t)
            here = os.path.join(args.work, name, t)
            l1, rest, mean_k = report(here + "_fit.csv")
            chi0 = chi_squares(base + ".h5", [base + "_mixture.h5"])[0][0]
            chi1 = chi_squares(here + ".h5", [here + "_mixture.h5"])[0][0]
            ratio = chi1 / chi0
            r = {"variant": name, "refine": settings.get("refine", "l1"), "refine_rgb": settings.get("refine_rgb", "0.5"),
                 "refine_kl": settings.get("refine_kl", "5"),
                 "refine_evaluations": settings.get("refine_evaluations", "150"), "table": t, "mean_k": mean_k,
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
