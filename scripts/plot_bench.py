#!/usr/bin/python3
"""Chart of `bsdfmix bench em` CSVs: point-component updates per second of every
implementation measured, one group of bars per K, log scale (PNG and SVG).

  scripts/plot_bench.py bench/results/em_k16_<machine>.csv bench/results/em_k50_<machine>.csv -o out/em_throughput

(docs/images/em_throughput.png is the PNG of that command, which `bench/reproduce.sh em` runs.)
"""

import argparse
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("csv", nargs="+", help="bench em CSVs (impl,k,cells,slices,iterations,seconds_per_iteration,pc_per_s[,reps,threads,...])")
    ap.add_argument("-o", "--out", required=True, help="output path without extension")
    a = ap.parse_args()
    rows = []
    for path in a.csv:
        try:
            with open(path, newline="") as f:
                rows += list(csv.DictReader(f))
        except OSError as e:
            print("plot_bench: error: cannot read %s: %s" % (path, e), file=sys.stderr)
            sys.exit(1)
    ks = sorted({int(r["k"]) for r in rows})
    impls = []
    for r in rows:
        name = r["impl"].split(" (")[0]
        if name not in impls:
            impls.append(name)
    fig, ax = plt.subplots(figsize=(8, 4.5), layout="constrained")
    width = 0.8 / len(impls)
    for i, impl in enumerate(impls):
        xs, ys = [], []
        for j, k in enumerate(ks):
            for r in rows:
                if r["impl"].split(" (")[0] == impl and int(r["k"]) == k:
                    xs.append(j + (i - (len(impls) - 1) / 2) * width)
                    ys.append(float(r["pc_per_s"]))
        ax.bar(xs, ys, width, label=impl)
        for x, y in zip(xs, ys):
            ax.text(x, y * 1.1, "%.3g G" % (y / 1e9) if y >= 1e8 else "%.3g M" % (y / 1e6), ha="center", fontsize=7)
    ax.set_yscale("log")
    ax.set_xticks(range(len(ks)))
    ax.set_xticklabels(["K = %d" % k for k in ks])
    ax.set_ylabel("point-component updates per second")
    device = next((r["impl"] for r in rows if r["impl"].startswith("bsdfmix")), "bsdfmix")
    ours = next((r for r in rows if r["impl"].startswith("bsdfmix")), {})
    if ours.get("cpu_model"):  # CSVs with the machine columns
        others = sorted({r.get("threads", "?") for r in rows if not r["impl"].startswith("bsdfmix")})
        title = "Weighted EM throughput on 90 x 180 slices, best of %s\n%s, %s logical CPUs: bsdfmix %s threads, others %s" % (
            ours.get("reps", "?"), ours["cpu_model"], ours.get("logical_cpus", "?"), ours.get("threads", "?"),
            "/".join(others))
    else:
        title = "Weighted EM throughput on 90 x 180 slices\n%s (peers and the reference: one core)" % device
    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    ax.grid(True, axis="y", which="both", alpha=0.3)
    for ext in ("png", "svg"):
        fig.savefig(a.out + "." + ext, dpi=130)
    print(a.out + ".png")


if __name__ == "__main__":
    main()
