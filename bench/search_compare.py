#!/usr/bin/python3
"""The Gaussian-count search before and after, side by side in one run of one binary.

Three methods (docs/fitting.md): `search: restarts` with `refine: none` (independent
k-means++ restarts at every candidate K: before), `search: smem` with `refine: none` (the
walk over K with split-and-merge moves), and `search: smem` with `refine: l1` (the walk, then
the final fits refined toward the least L1 error: after, the defaults), on the
thesis-scale polyester table (180 slices of 90 x 180) and the three RGL materials of
data/rgl (90 slices of 90 x 180 each): the search with the default settings (K in
[1, 32]: chosen K, L1 at the chosen K, wall time) and pinned K = 8 and 16 (L1 median and
p90, wall time). Writes bench/results/search_compare.csv (with the CPU model) and, with
--chart, docs/images/search_l1_vs_k.png: L1 against K before and after for the sharpest
and the broadest polyester slice.

    bench/search_compare.py [--bsdfmix build/bsdfmix] [--work out/bench_search]
                            [--tables polyester,satin,paper,sunflower] [--fixed 8,16] [--runs 3]
                            [--csv bench/results/search_compare.csv] [--chart]
"""
import argparse
import csv
import os
import statistics
import subprocess
import sys
import time
from machine import cpu_model  # noqa: E402  (bench/machine.py)

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RGL = {
    "satin": "satin_rosaline_rgb.bsdf",
    "paper": "paper_white_rgb.bsdf",
    "sunflower": "cg_sunflower_rgb.bsdf",
}


def make_table(bsdfmix, work, name):
    path = os.path.join(work, name + ".h5")
    if os.path.exists(path):
        return path
    if name in RGL:
        cmd = [bsdfmix, "import", "rgl", os.path.join(ROOT, "data", "rgl", RGL[name]), "-o", path, "--quiet"]
    else:
        cmd = [bsdfmix, "generate", "fiber", "-q", "--preset", name, "--theta-o", "180", "--theta-i", "90",
               "--phi-i", "180", "-o", path]
    subprocess.run(cmd, check=True)
    return path


METHODS = (("restarts", "none"), ("smem", "none"), ("smem", "l1"))


def fit(bsdfmix, work, table, stem, search, k_min=1, k_max=32, extra="", refine="l1", runs=1):
    out = os.path.join(work, stem)
    cfg = out + ".yaml"
    with open(cfg, "w") as f:
        f.write(f"table: {table}\nfit:\n  output: {out}_mixture.h5\n  report: {out}_fit.csv\n"
                f"  search_report: {out}_search.csv\n  k_min: {k_min}\n  k_max: {k_max}\n  search: {search}\n"
                f"  refine: {refine}\n{extra}")
    seconds = None
    for _ in range(runs):  # the best wall time; the fits are the same every run
        if os.path.exists(out + "_mixture.h5"):
            os.remove(out + "_mixture.h5")
        start = time.monotonic()
        subprocess.run([bsdfmix, "fit", "-q", cfg], check=True, stdout=subprocess.DEVNULL if seconds else None)
        seconds = min(seconds or 1e30, time.monotonic() - start)
    with open(out + "_fit.csv") as f:
        rows = list(csv.DictReader(f))
    ks = [int(r["k"]) for r in rows]
    l1 = sorted(float(r["l1_rel"]) for r in rows)
    p90 = l1[min(len(l1) - 1, max(0, -(-9 * len(l1) // 10) - 1))]
    return {"slices": len(rows), "mean_k": statistics.mean(ks), "l1_median": l1[len(l1) // 2], "l1_p90": p90,
            "seconds": seconds, "rows": rows}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--bsdfmix", default=os.path.join(ROOT, "build", "bsdfmix"))
    ap.add_argument("--work", default=os.path.join(ROOT, "out", "bench_search"))
    ap.add_argument("--tables", default="polyester,satin,paper,sunflower")
    ap.add_argument("--fixed", default="8,16")
    ap.add_argument("--csv", default=os.path.join(ROOT, "bench", "results", "search_compare.csv"))
    ap.add_argument("--runs", type=int, default=3, help="runs per row; a row's time is the best")
    ap.add_argument("--chart", action="store_true")
    args = ap.parse_args()
    os.makedirs(args.work, exist_ok=True)
    os.makedirs(os.path.dirname(args.csv), exist_ok=True)
    cpu = cpu_model()
    fixed = [int(k) for k in args.fixed.split(",") if k]
    results = []
    for name in [t for t in args.tables.split(",") if t]:
        table = make_table(args.bsdfmix, args.work, name)
        for search, refine in METHODS:
            stem = f"{name}_{search}_{refine}"
            r = fit(args.bsdfmix, args.work, table, f"{stem}_search", search, refine=refine, runs=args.runs)
            print(f"{name:10s} {search:8s} {refine:4s} search: {r['slices']} slices, mean K {r['mean_k']:.2f}, L1 "
                  f"median {100 * r['l1_median']:.2f}% p90 {100 * r['l1_p90']:.2f}%, {r['seconds']:.1f} s", flush=True)
            results.append((name, search, refine, "search", r))
            for k in fixed:
                r = fit(args.bsdfmix, args.work, table, f"{stem}_k{k}", search, k, k, refine=refine, runs=args.runs)
                print(f"{name:10s} {search:8s} {refine:4s} K = {k:2d}: L1 median {100 * r['l1_median']:.2f}% p90 "
                      f"{100 * r['l1_p90']:.2f}%, {r['seconds']:.1f} s", flush=True)
                results.append((name, search, refine, f"k{k}", r))
    if not results:  # --tables "": the chart alone
        if args.chart:
            chart(args)
        return 0
    with open(args.csv, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["table", "search", "refine", "run", "slices", "mean_k", "l1_median", "l1_p90", "seconds", "runs",
                    "cpu"])
        for name, search, refine, run, r in results:
            w.writerow([name, search, refine, run, r["slices"], f"{r['mean_k']:.3f}", f"{r['l1_median']:.5f}",
                        f"{r['l1_p90']:.5f}", f"{r['seconds']:.1f}", args.runs, cpu])
    print("wrote", args.csv)
    if args.chart:
        chart(args)
    return 0


def chart(args):
    """L1 against K, before and after, for the sharpest and the broadest polyester slice
    (the largest and the smallest chosen K of the `restarts` search) and a satin slice
    at theta_o 45 degrees (a broad measured lobe over a diffuse base): both searches with
    k_penalty 0 and refine none on those slices, so that every K is fitted by EM alone,
    and the final fits of every K from 1 to 16 pinned (4 restarts of 300 iterations and a
    split-and-merge round), without and with the L1 refinement."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    def report(table_name):
        path = os.path.join(args.work, f"{table_name}_restarts_none_search_fit.csv")
        if not os.path.exists(path):
            table = make_table(args.bsdfmix, args.work, table_name)
            fit(args.bsdfmix, args.work, table, f"{table_name}_restarts_none_search", "restarts", refine="none")
        with open(path) as f:
            return list(csv.DictReader(f))

    rows = report("polyester")
    satin = report("satin")
    panels = [("polyester", "sharp", max(rows, key=lambda r: (int(r["k"]), float(r["l1_rel"])))),
              ("polyester", "broad", min(rows, key=lambda r: (int(r["k"]), float(r["l1_rel"])))),
              ("satin", "measured", min(satin, key=lambda r: abs(float(r["theta_o"]) - 0.7854)))]
    fig, axes = plt.subplots(1, len(panels), figsize=(15, 4.2))
    for ax, (name, label, row) in zip(axes, panels):
        table = make_table(args.bsdfmix, args.work, name)
        theta = float(row["theta_o"])
        slice_index = int(row["slice"])
        for search, style in (("restarts", "o-"), ("smem", "s-")):
            stem = f"chart_{name}_{label}_{search}"
            fit(args.bsdfmix, args.work, table, stem, search, refine="none",
                extra=f"  k_penalty: 0.0\n  theta_o: [{theta!r}]\n")
            best = {}
            with open(os.path.join(args.work, stem + "_search.csv")) as f:
                for r in csv.DictReader(f):
                    if int(r["slice"]) != slice_index:
                        continue
                    k, l1 = int(r["k"]), float(r["l1_rel"])
                    best[k] = min(best.get(k, 9.0), l1)
            ks = sorted(best)
            ax.plot(ks, [100 * best[k] for k in ks], style, ms=3,
                    label="before: search, k-means++ restarts" if search == "restarts" else "search, walk + split-and-merge")
        for refine, style, text in (("none", "v--", "final fits at pinned K, EM only"),
                                    ("l1", "^-", "after: final fits at pinned K + L1 refinement")):
            pinned = {}
            for k in range(1, 17):
                r = fit(args.bsdfmix, args.work, table, f"chart_{name}_{label}_{refine}_k{k}", "smem", k, k,
                        refine=refine, extra=f"  theta_o: [{theta!r}]\n")
                pinned[k] = next(float(x["l1_rel"]) for x in r["rows"] if int(x["slice"]) == slice_index)
            ks = sorted(pinned)
            ax.plot(ks, [100 * pinned[k] for k in ks], style, ms=3, label=text)
        ax.set_title(f"{name} slice {slice_index} (theta_o {theta:.2f} rad), {label}")
        ax.set_xlabel("K")
        ax.set_ylabel("relative L1 error (%)")
        ax.set_yscale("log")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    out = os.path.join(ROOT, "docs", "images", "search_l1_vs_k.png")
    fig.savefig(out, dpi=100)
    print("wrote", out)


if __name__ == "__main__":
    sys.exit(main())
