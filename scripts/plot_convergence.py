#!/usr/bin/python3
"""Charts of bsdfmix convergence studies, PNG and SVG (matplotlib).

  convergence_samples   rel_rmse against N per estimator (the thesis's figure 4.4), for
                        the sharpest and the broadest slice (or material) studied
  convergence_time      the same against time per estimate (N x ns_per_sample): equal time
  variance_reduction    variance of us_tab over each estimator's at the largest N, against
                        theta_o (below 1: worse than uniform sampling), with the tail-risk
                        prediction of the tail CSV
  speed_accuracy        rel_rmse at N = 1024 against ns per sample, every estimator on one chart

Several studies (materials) can be given: --csv a.csv b.csv --tail a_tail.csv b_tail.csv.

Example:
  scripts/plot_convergence.py --csv out/polyester_convergence.csv --tail out/polyester_convergence_tail.csv -o out/charts
"""

import argparse
import csv
import math
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib import ticker  # noqa: E402

ESTIMATORS = ["us_tab", "us_gmm", "is_tab", "is_gmm", "mis_tab", "cdf_tab",
              "light", "mis_light_cdf", "mis_light_gmm", "product", "mis_product", "is_rgl", "mis_light_rgl"]
STYLE = {
    "us_tab": dict(color="#7f7f7f", marker="o", ls="-"),
    "us_gmm": dict(color="#bcbd22", marker="v", ls="--"),
    "is_tab": dict(color="#d62728", marker="s", ls="-"),
    "is_gmm": dict(color="#ff9896", marker="D", ls="--"),
    "mis_tab": dict(color="#1f77b4", marker="^", ls="-", lw=2.6),
    "cdf_tab": dict(color="#2ca02c", marker="P", ls=":"),
    "light": dict(color="#e6ab02", marker="*", ls="-."),
    "mis_light_cdf": dict(color="#8c564b", marker="X", ls="-"),
    "mis_light_gmm": dict(color="#e377c2", marker="h", ls="--"),
    "product": dict(color="#17becf", marker="<", ls=":"),
    "mis_product": dict(color="#9467bd", marker=">", ls="-", lw=2.6),
    "is_rgl": dict(color="#393b79", marker="d", ls="-."),
    "mis_light_rgl": dict(color="#637939", marker="p", ls="-."),
}
LABEL = {
    "us_tab": "us_tab (uniform, table)",
    "us_gmm": "us_gmm (uniform, stand-in)",
    "is_tab": "is_tab (mixture, table)",
    "is_gmm": "is_gmm (mixture, stand-in)",
    "mis_tab": "mis_tab (mixture + 10% uniform): BSDF-only default",
    "cdf_tab": "cdf_tab (table CDF, memory-hungry)",
    "light": "light (light sampling alone)",
    "mis_light_cdf": "mis_light_cdf (light + table CDF): renderer baseline",
    "mis_light_gmm": "mis_light_gmm (light + mixture)",
    "product": "product (BSDF x lighting mixture alone)",
    "mis_product": "mis_product (product + light + uniform): default with lighting",
    "is_rgl": "is_rgl (the RGL file's warps): measured baseline",
    "mis_light_rgl": "mis_light_rgl (light + the RGL file's warps)",
}


def fail(msg):
    print("plot_convergence: error: " + msg, file=sys.stderr)
    sys.exit(1)


def read_csv(path, needed):
    try:
        with open(path, newline="") as f:
            rows = list(csv.DictReader(f))
    except OSError as e:
        fail("cannot read %s: %s" % (path, e))
    if rows:
        missing = [c for c in needed if c not in rows[0]]
        if missing:
            fail("%s: missing columns %s" % (path, ", ".join(missing)))
    return rows


def fnum(x):
    try:
        return float(x)
    except ValueError:
        return float("nan")


def save(fig, out, name):
    for ext in ("png", "svg"):
        fig.savefig(os.path.join(out, name + "." + ext), dpi=110, bbox_inches="tight")
    plt.close(fig)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--csv", nargs="+", required=True, help="convergence CSV(s)")
    ap.add_argument("--tail", nargs="*", default=[], help="tail-risk CSV(s) (<csv stem>_tail.csv)")
    ap.add_argument("-o", "--out", required=True, help="output directory")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)

    cols = "table,theta_o,phi_o,scene,estimator,samples,runs,mean,reference,rmse,rel_rmse,ns_per_sample".split(",")
    rows = []
    for p in a.csv:
        rows += read_csv(p, cols)
    if not rows:
        fail("no rows in " + ", ".join(a.csv))
    tails = []
    for p in a.tail:
        tails += read_csv(p, ["table", "theta_o", "relvar_us", "relvar_is", "relvar_mis"])

    # series[(table, theta_o, phi_o, scene, estimator)] = sorted [(N, rel_rmse, ns)]
    series = {}
    for r in rows:
        key = (r["table"], fnum(r["theta_o"]), fnum(r["phi_o"]), r["scene"], r["estimator"])
        series.setdefault(key, []).append((int(r["samples"]), fnum(r["rel_rmse"]), fnum(r["ns_per_sample"])))
    for v in series.values():
        v.sort()
    tables = sorted({k[0] for k in series})
    scenes = []
    for k in series:
        if k[3] not in scenes:
            scenes.append(k[3])
    dirs = sorted({(k[0], k[1], k[2]) for k in series})
    tail = {(t["table"], round(fnum(t["theta_o"]), 6), round(fnum(t.get("phi_o", "0")), 6)): t for t in tails}

    def relvar_us(d):
        # sharpness: the uniform estimator's variance (tail CSV, else measured at the largest N)
        t = tail.get((d[0], round(d[1], 6), round(d[2], 6)))
        if t:
            return fnum(t["relvar_us"])
        s = series.get((d[0], d[1], d[2], scenes[0], "us_tab"))
        return s[-1][1] ** 2 * s[-1][0] if s else 0.0

    # The panels: per material its sharpest direction; with one material, its sharpest and broadest.
    picks = []
    if len(tables) == 1:
        ds = sorted(dirs, key=relvar_us)
        picks = [("sharp", ds[-1])] + ([("broad", ds[0])] if len(ds) > 1 else [])
    else:
        allsharp = sorted(dirs, key=relvar_us)
        for t in tables:
            ds = [d for d in allsharp if d[0] == t]
            picks.append(("", ds[-1]))
        picks.sort(key=lambda p: -relvar_us(p[1]))
        picks = [("sharp" if i == 0 else ("broad" if i == len(picks) - 1 else ""), p[1]) for i, p in enumerate(picks)]
    show_scenes = scenes[:2]

    def is_tab_fails(d, scene):
        us = series.get(d + (scene, "us_tab"))
        it = series.get(d + (scene, "is_tab"))
        t = tail.get((d[0], round(d[1], 6), round(d[2], 6)))
        measured = us and it and it[-1][1] > us[-1][1]
        predicted = t and not (fnum(t["relvar_is"]) <= fnum(t["relvar_us"]))
        return measured, predicted

    for mode in ("samples", "time"):
        fig, axes = plt.subplots(len(show_scenes), len(picks), figsize=(6.2 * len(picks), 4.6 * len(show_scenes)),
                                 squeeze=False)
        for i, scene in enumerate(show_scenes):
            for j, (kind, d) in enumerate(picks):
                ax = axes[i][j]
                for e in ESTIMATORS:
                    s = series.get(d + (scene, e))
                    if not s:
                        continue
                    x = [n for n, _, _ in s] if mode == "samples" else [n * ns * 1e-3 for n, _, ns in s]
                    y = [max(rr, 1e-12) for _, rr, _ in s]
                    st = dict(STYLE[e])
                    lw = st.pop("lw", 1.5)
                    ax.plot(x, y, label=LABEL[e], lw=lw, ms=3.5, **st)
                us = series.get(d + (scene, "us_tab"))
                if us and mode == "samples":
                    n0, r0 = us[-1][0], us[-1][1]
                    ax.plot([n for n, _, _ in us], [r0 * math.sqrt(n0 / n) for n, _, _ in us], color="k", lw=0.6,
                            ls=(0, (1, 3)), label="1/sqrt(N)")
                ax.set_xscale("log", base=2 if mode == "samples" else 10)
                ax.set_yscale("log")
                ax.grid(True, which="major", alpha=0.3)
                ax.set_xlabel("samples N" if mode == "samples" else "time per estimate (microseconds): N x ns_per_sample")
                ax.set_ylabel("relative RMSE")
                title = "%s theta_o = %.0f deg, scene %s" % (d[0], math.degrees(d[1]), scene)
                ax.set_title(("[%s] " % kind if kind else "") + title, fontsize=10)
                measured, predicted = is_tab_fails(d, scene)
                if (measured or predicted) and series.get(d + (scene, "is_tab")):
                    why = "is_tab above us_tab here" if measured else "is_tab: unbounded f/pdf in the tails"
                    ax.text(0.02, 0.03, why + "\n(Gaussian tails fall faster than f)\n-> use mis_tab",
                            transform=ax.transAxes, fontsize=8, color=STYLE["is_tab"]["color"],
                            bbox=dict(facecolor="white", alpha=0.8, edgecolor=STYLE["is_tab"]["color"]))
        axes[0][0].legend(fontsize=7, loc="lower left")
        fig.subplots_adjust(hspace=0.32)
        fig.suptitle("Monte Carlo convergence: relative RMSE against %s (is_gmm/us_gmm flatten at the stand-in's bias)"
                     % ("samples" if mode == "samples" else "equal time"), fontsize=11)
        save(fig, a.out, "convergence_" + mode)

    # Variance reduction against theta_o.
    fig, axes = plt.subplots(1, len(show_scenes), figsize=(6.5 * len(show_scenes), 4.6), squeeze=False)
    for i, scene in enumerate(show_scenes):
        ax = axes[0][i]
        for t in tables:
            tds = sorted(d for d in dirs if d[0] == t)
            mk = ["-", "--", ":", "-."][tables.index(t) % 4]
            for e in ESTIMATORS:
                if e in ("us_tab", "cdf_tab"):
                    continue
                xs, ys = [], []
                for d in tds:
                    us, s = series.get(d + (scene, "us_tab")), series.get(d + (scene, e))
                    if us and s and s[-1][1] > 0:
                        xs.append(math.degrees(d[1]))
                        ys.append((us[-1][1] / s[-1][1]) ** 2)
                if xs:
                    ax.plot(xs, ys, color=STYLE[e]["color"], marker=STYLE[e]["marker"], ls=mk,
                            label="%s %s" % (t, e) if len(tables) > 1 else e)
            if scene == scenes[0] and tails:
                for which, col in (("relvar_is", "is_tab"), ("relvar_mis", "mis_tab")):
                    xs, ys = [], []
                    for d in tds:
                        tt = tail.get((d[0], round(d[1], 6), round(d[2], 6)))
                        if tt and fnum(tt[which]) > 0:
                            xs.append(math.degrees(d[1]))
                            ys.append(fnum(tt["relvar_us"]) / fnum(tt[which]))
                    if xs:
                        ax.plot(xs, [max(y, 1e-6) for y in ys], color=STYLE[col]["color"], ls="none", marker="x",
                                ms=9, label="%s predicted (tail CSV, L=1)" % col if t == tables[0] else None)
        ax.axhline(1.0, color="k", lw=0.8)
        ax.text(0.01, 1.0, " uniform sampling", va="bottom", fontsize=8, transform=ax.get_yaxis_transform())
        ax.set_yscale("log")
        ax.set_xlabel("theta_o (degrees)")
        ax.set_ylabel("MSE of us_tab / MSE of the estimator (variance; + bias for *_gmm)")
        ax.set_title("variance reduction at the largest N, scene %s" % scene, fontsize=10)
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7)
    save(fig, a.out, "variance_reduction")

    # Speed against accuracy at N = 1024 (or the largest N below).
    fig, ax = plt.subplots(figsize=(7.5, 5.2))
    all_x = []
    for e in ESTIMATORS:
        xs, ys = [], []
        for k, s in series.items():
            if k[4] != e:
                continue
            pts = [p for p in s if p[0] <= 1024]
            if pts:
                xs.append(pts[-1][2])
                ys.append(max(pts[-1][1], 1e-9))
        if xs:
            ax.scatter(xs, ys, color=STYLE[e]["color"], marker=STYLE[e]["marker"], s=36, label=LABEL[e], alpha=0.8)
            all_x += xs
    # A log axis over less than a decade labels its minor ticks in scientific notation, one
    # on top of the other: plain numbers at 1, 2, 3 and 5 per decade instead, or a linear
    # axis where the costs span less than a factor of 3.
    if all_x and max(all_x) < 3 * min(all_x):
        ax.xaxis.set_major_locator(ticker.MaxNLocator(nbins=6))
    else:
        ax.set_xscale("log")
        ax.xaxis.set_major_locator(ticker.LogLocator(base=10, subs=(1.0, 2.0, 3.0, 5.0)))
        ax.xaxis.set_major_formatter(ticker.FuncFormatter(lambda v, _: "%g" % v))
        ax.xaxis.set_minor_formatter(ticker.NullFormatter())
    ax.set_yscale("log")
    ax.set_xlabel("cost: ns per sample (device)")
    ax.set_ylabel("relative RMSE at N = 1024")
    ax.set_title("speed against accuracy, every slice and scene studied (lower left is better)", fontsize=10)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7)
    save(fig, a.out, "speed_accuracy")
    print("plot_convergence: convergence_samples, convergence_time, variance_reduction, speed_accuracy in " + a.out)


if __name__ == "__main__":
    main()
