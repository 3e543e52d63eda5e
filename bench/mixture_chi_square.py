#!/usr/bin/python3
"""Importance sampling by a mixture file, slice by slice: the chi-square divergence of each
slice of a table from its mixture, sum_i w_i^2 / q_i - 1 over the cells (w the slice's
integrand weights normalized to sum 1, q = 0.9 A p + 0.1 / N the mixture's cell
probabilities with 10% uniform mixed in): the variance per sample of importance sampling
the slice by q. Compares two mixture files of the same table (before, after): the median,
p90 and largest per-slice ratio after / before, and the mean divergence of each, with the
relative L1 error medians. With --csv, appends one row per comparison.

    bench/mixture_chi_square.py TABLE.h5 BEFORE_mixture.h5 AFTER_mixture.h5 [--label NAME] [--csv FILE]

docs/studies/search.md ("The L1 refinement in full") quotes the rows of bench/results/search_chi_square.csv:
    for t in satin paper sunflower; do bench/mixture_chi_square.py out/bench_search/$t.h5 \\
      out/bench_search/${t}_smem_none_search_mixture.h5 out/bench_search/${t}_smem_l1_search_mixture.h5 \\
      --label $t --csv bench/results/search_chi_square.csv; done
(after bench/search_compare.py has made those files).
"""
import argparse
import csv
import os
import sys

import h5py
import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "scripts"))
import bsdfmix_import  # noqa: E402

bsdfmix = bsdfmix_import.load()


def chi_squares(table_path, mixture_paths):
    """Per mixture file, over the table's non-zero slices: the chi-square divergence of each
    slice from the mixture (10% uniform mixed in) and the file's l1_rel of that slice. The
    mixture's probability of a cell is its density at the cell center (the header's
    pdf_param, through the Python module) times the cell area."""
    t = h5py.File(table_path, "r")["table"]
    theta, phi = t["theta_i"][:], t["phi_i"][:]
    area = (theta[1] - theta[0]) * (phi[1] - phi[0])
    tt, pp = np.meshgrid(theta, phi, indexing="ij")
    jac = np.cos(tt) * np.sin(tt) if t.attrs["domain"] == "hemisphere" else np.cos(tt)
    mixes = [bsdfmix.load_mixture(f) for f in mixture_paths]
    l1_rel = [bsdfmix.mixture_info(f)["l1_rel"] for f in mixture_paths]
    chi, l1 = [[] for _ in mixes], [[] for _ in mixes]
    for s in range(len(mixes[0].slices)):
        w = t["values"][s, 0] * jac * area
        if not w.sum() > 0:
            continue
        w = w / w.sum()
        for i, mix in enumerate(mixes):
            q = 0.9 * mix.slices[s].pdf_param(tt, pp) * area + 0.1 / w.size
            chi[i].append(float((w * w / q).sum() - 1))
            l1[i].append(float(l1_rel[i][s]))
    return np.array(chi), l1


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("table")
    ap.add_argument("before")
    ap.add_argument("after")
    ap.add_argument("--label", default="")
    ap.add_argument("--csv")
    args = ap.parse_args()
    chi, l1 = chi_squares(args.table, (args.before, args.after))
    ratio = chi[1] / chi[0]
    row = {"label": args.label or os.path.basename(args.table), "slices": chi.shape[1],
           "l1_median_before": np.median(l1[0]), "l1_median_after": np.median(l1[1]),
           "chi_mean_before": chi[0].mean(), "chi_mean_after": chi[1].mean(),
           "ratio_median": np.median(ratio), "ratio_p90": np.percentile(ratio, 90), "ratio_max": ratio.max()}
    print(", ".join(f"{k} {v:.4f}" if isinstance(v, float) else f"{k} {v}" for k, v in row.items()))
    if args.csv:
        new = not os.path.exists(args.csv)
        with open(args.csv, "a", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(row))
            if new:
                w.writeheader()
            w.writerow({k: (f"{v:.5f}" if isinstance(v, float) else v) for k, v in row.items()})
    return 0


if __name__ == "__main__":
    sys.exit(main())
