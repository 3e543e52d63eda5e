#!/usr/bin/python3
"""The mixture stand-in against what a user would keep instead at the same bytes: a smaller
table and spherical harmonics, per slice of the full-resolution table.

For each material (the four fiber presets, generated at 90 theta_o x 90 x 180, and every RGL
material of data/rgl/, imported at the same grid) and each byte budget (2, 4, 8, 16, 32 KiB),
the best configuration of each representation that fits in the budget (the lowest median RGB
error, less its negative share, over every table slice):

- mixture: the project's fits (`bsdfmix fit`, K in [1, K max], seed 1, the defaults otherwise)
  on every n-th theta_o row, packed `ragged_f32` (`bsdfmix pack`; bytes: its payload), compared
  at every table slice by `bsdfmix compare`; it samples itself;
- table: the smaller table (bench/rival_table.py), evaluated by trilinear interpolation and
  sampled by the CDF of its luminance, the CDF's bytes counted; table_eval: the same without a
  CDF, evaluation only;
- sh: spherical harmonics per theta_o slice (bench/rival_sh.py), sampled by a tabulated CDF of
  the clamped luminance that takes a quarter of the bytes; sh_eval: coefficients only, which
  cannot be sampled.

Per row: bytes; median and p90 luminance L1 and RGB error over every table slice (compare's
measures, bench/compact_metrics.py), and for the mixture the median RGB error of the slices it
fitted and of those it blends between them; the largest energy error; the evaluation cost in ns (f
in R, G, B at random (theta_o, theta_i, phi_i), best of 3, every representation timed in the same
run: the rivals by a vectorised numpy evaluation, the mixture by the header's `eval_rgb` through the
Python module, one point at a time, as a renderer calls it); the relative variance per sample of importance sampling
the luminance integral under constant light (median and p90 over the slices) where the
representation samples (and the largest share of the integral it never samples), and the same
with 10% of the samples uniform in solid angle (`mis_tab` at `uniform_fraction: 0.1`); the
configuration; the table's largest mirror asymmetry in phi_i (the share of a slice's RGB L1
between f(phi) and f(-phi), which the rivals take as 0); the machine and the command.

    /usr/bin/python3 bench/compact_rivals.py [--materials a,b] [--quick] [--csv F] [--png P]
                                             [--chart-only] [--keep-tables polyester,satin_rosaline]

--quick: satin_rosaline and silk, budgets 8 KiB only. The representations at 8 KiB of the
--keep-tables materials are written as full-resolution tables for the image study
(bench/compact_image.py).
"""
import argparse
import csv
import math
import os
import subprocess
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import compact_metrics as cm  # noqa: E402
import mixture_eval  # noqa: E402
import rival_sh  # noqa: E402
import rival_table  # noqa: E402
from machine import cpu_model  # noqa: E402  (bench/machine.py)

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BIN = os.path.join(ROOT, "build", "bsdfmix")
WORK = os.path.join(ROOT, "out", "compact_rivals")
FIBERS = ["silk", "cotton", "polyester", "wool"]
RGL = ["satin_rosaline", "paper_white", "cg_sunflower", "cc_iris_purple_gem"]
BUDGETS = [2048, 4096, 8192, 16384, 32768]
ROWS = 90
# (every n-th theta_o row, K max) of the mixture fits: 2 to 90 slices
# The mixture: K max tried per budget, and a first guess of the bytes per fitted slice (payload less the
# axes); the fits themselves then say how many rows fit in the budget.
K_MAX = {2048: (4, 8), 4096: (4, 16), 8192: (4, 8, 16), 16384: (16,), 32768: (16,)}
GUESS = {4: 200, 8: 350, 16: 450}
L_MAX = {"fiber": 48, "hemisphere": 64}  # the largest degree fitted (the 32 KiB budgets need less)
COLUMNS = ["material", "domain", "representation", "budget", "bytes", "bytes_eval", "config", "median_l1", "p90_l1",
           "median_rgb", "p90_rgb", "median_rgb_fitted", "median_rgb_between", "max_energy", "eval_ns", "eval_method", "relvar_median",
           "relvar_p90", "missed_max", "relvar_uniform10_median", "relvar_uniform10_p90", "slices", "phi_asymmetry",
           "fit_seconds", "cpu", "cores", "command"]


def run(cmd):
    r = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit("failed: %s\n%s%s" % (" ".join(cmd), r.stdout, r.stderr))
    return r.stdout


def make_table(mat):
    path = os.path.join(WORK, "%s_table.h5" % mat)
    if not os.path.exists(path):
        grid = ["--theta-o", str(ROWS), "--theta-i", "90", "--phi-i", "180", "-o", path, "--quiet"]
        if mat in FIBERS:
            run([BIN, "generate", "fiber", "--preset", mat] + grid)
        else:
            run([BIN, "import", "rgl", os.path.join(ROOT, "data", "rgl", mat + "_rgb.bsdf")] + grid)
    return path


# ---- the mixture ----

def fit_mixture(mat, table_path, axis, every, kmax):
    """Fits, packs and compares one configuration; returns its row fields and the packed file."""
    stem = os.path.join(WORK, "%s_e%d_k%d" % (mat, every, kmax))
    mixture = stem + ".h5"
    chosen = axis[::every]
    if not os.path.exists(mixture):
        with open(stem + ".yaml", "w") as f:
            f.write("table: %s\nfit:\n  output: %s\n  report: %s_fit.csv\n  search_report: %s_search.csv\n"
                    "  k_min: 1\n  k_max: %d\n  seed: 1\n  theta_o: [%s]\n"
                    % (table_path, mixture, stem, stem, kmax, ", ".join("%.17g" % t for t in chosen)))
        t0 = time.time()
        run([BIN, "fit", stem + ".yaml", "--quiet"])
        with open(stem + ".seconds", "w") as f:
            f.write("%.1f\n" % (time.time() - t0))
    packed = stem + "_ragged_f32.h5"
    line = run([BIN, "pack", mixture, "-o", packed, "--storage", "ragged_f32", "--quiet"])
    payload = int(line.rsplit("->", 1)[1].split()[0])
    cmp_csv = stem + "_compare.csv"
    run([BIN, "compare", packed, table_path, "--csv", cmp_csv, "--quiet"])
    rows = list(csv.DictReader(open(cmp_csv)))
    e = dict(l1=np.array([float(r["l1_rel"]) for r in rows]),
             rgb_error=np.array([float(r["rgb_error"]) for r in rows]),
             neg_share=np.array([float(r["rgb_negative_share"]) for r in rows]),
             energy_y=np.array([float(r["energy"]) for r in rows]),
             energy_c=np.array([[float(r["energy_" + c]) for c in "rgb"] for r in rows]),
             noise=np.array([[c in r["noise"] for c in "rgb"] for r in rows]))
    fitted = np.array([r["fitted"] == "1" for r in rows])
    rgb = e["rgb_error"] * (1 - e["neg_share"])
    stats = cm.summary(e)
    stats["median_rgb_fitted"] = cm.quantile(rgb[fitted], 0.5)
    stats["median_rgb_between"] = cm.quantile(rgb[~fitted], 0.5) if (~fitted).any() else float("nan")
    return dict(bytes=payload, bytes_eval=payload, config="every %d rows (%d slices), K max %d" % (every, len(chosen), kmax),
                stats=stats, packed=packed, seconds=float(open(stem + ".seconds").read()))


# ---- evaluation cost: f in R, G, B at random (theta_o, theta_i, phi_i), numpy, vectorised ----

def queries(table, n, seed=7):
    r = np.random.default_rng(seed)
    return (r.uniform(table.theta_o[0], table.theta_o[-1], n), r.uniform(table.lo, table.hi, n),
            r.uniform(-math.pi, math.pi, n))


def clamp_bracket(x, lo, hi, n):
    u = np.clip((x - lo) / (hi - lo) * n - 0.5, 0, n - 1)
    i0 = np.minimum(np.floor(u).astype(int), max(n - 2, 0))
    return i0, np.minimum(i0 + 1, n - 1), u - i0


def table_points(table, coarse, q):
    n_to, n_ti, n_pi = coarse.shape[:3]
    to, ti, pi = q
    a0, a1, fa = clamp_bracket(to, table.lo, table.hi, n_to)
    b0, b1, fb = clamp_bracket(ti, table.lo, table.hi, n_ti)
    u = (pi + math.pi) / (2 * math.pi) * n_pi - 0.5
    c0 = np.floor(u).astype(int)
    fc = u - c0
    c1 = (c0 + 1) % n_pi
    c0 %= n_pi
    out = 0
    for a, wa in ((a0, 1 - fa), (a1, fa)):
        for b, wb in ((b0, 1 - fb), (b1, fb)):
            w = (wa * wb)[:, None]
            out = out + w * ((1 - fc)[:, None] * coarse[a, b, c0] + fc[:, None] * coarse[a, b, c1])
    return out


def sh_points(fit, coef, l_max, q):
    table, hemisphere = fit.table, fit.hemisphere
    to, ti, pi = q
    n_to = coef.shape[0]
    a0, a1, fa = clamp_bracket(to, table.lo, table.hi, n_to)
    c = (1 - fa)[:, None, None] * coef[a0] + fa[:, None, None] * coef[a1]  # [N, n, 3]
    colat = (math.pi / 2 - ti) if table.domain == "fiber" else ti
    b = rival_sh.basis(l_max, hemisphere, colat, np.abs(pi))
    v = np.maximum(np.einsum("pn,pnk->pk", b, c), 0.0)
    return v / np.cos(ti)[:, None] if fit.cosine else v


def mixture_points(mix, table, q):
    """The mixture's f in R, G, B at the query points: the header's eval_rgb through the module."""
    to, ti, pi = q
    return mixture_eval.at_points(mix, to, ti, pi)


def best_time(fn, runs=3):
    best = float("inf")
    for _ in range(runs):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


# ---- the rivals' configurations under a budget ----

def table_configs(budget, with_cdf):
    """(n_to, n_ti, n_pi) under the budget: theta_o, theta_i and phi_i reduced together, the theta_o
    count at half, equal and twice the others' scale."""
    out = []
    for r in (0.5, 0.75, 1.0, 1.5, 2.0):
        best = None
        for n in range(2, 91):
            n_to = max(2, int(round(r * n)))
            c = (n_to, n, 2 * n)
            b = rival_table.eval_bytes(*c) + (rival_table.cdf_bytes(*c) if with_cdf else 0)
            if b <= budget:
                best = c
        if best and best not in out:
            out.append(best)
    return out


def sh_configs(budget, hemisphere, with_cdf):
    """(n_to, l_max, n_c) under the budget, n_to from 2 up, l_max the largest that fits; with a CDF,
    the CDF takes a quarter of the budget."""
    out = []
    for n_to in (2, 3, 4, 5, 6, 8, 10, 12, 16, 20):
        coef_budget = budget * (0.75 if with_cdf else 1.0)
        l_best = None
        for l in range(0, L_MAX["hemisphere" if hemisphere else "fiber"] + 1):
            if rival_sh.eval_bytes(n_to, l, hemisphere) <= coef_budget:
                l_best = l
        if l_best is None or l_best < 2:
            continue
        n_c = 0
        if with_cdf:
            rest = budget - rival_sh.eval_bytes(n_to, l_best, hemisphere)
            while rival_sh.cdf_bytes(n_to, n_c + 1) <= rest:
                n_c += 1
            if n_c < 2:
                continue
        out.append((n_to, l_best, n_c))
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--materials", default=",".join(FIBERS + RGL))
    ap.add_argument("--budgets", default=",".join(str(b) for b in BUDGETS))
    ap.add_argument("--quick", action="store_true", help="satin_rosaline and silk at 8 KiB")
    ap.add_argument("--csv", default=os.path.join(ROOT, "bench", "results", "compact_rivals.csv"))
    ap.add_argument("--png", default=os.path.join(ROOT, "docs", "images", "compact_rivals.png"))
    ap.add_argument("--chart-only", action="store_true")
    ap.add_argument("--keep-tables", default="polyester,satin_rosaline",
                    help="materials whose 8 KiB representations are written as tables for bench/compact_image.py")
    a = ap.parse_args()
    if a.chart_only:
        chart(list(csv.DictReader(open(a.csv))), a.png)
        return
    mats, budgets = a.materials.split(","), [int(b) for b in a.budgets.split(",")]
    if a.quick:
        mats, budgets = ["satin_rosaline", "silk"], [8192]
    keep = set(a.keep_tables.split(",")) if a.keep_tables else set()
    os.makedirs(WORK, exist_ok=True)
    cpu, cores = cpu_model(), os.cpu_count()
    command = "/usr/bin/python3 bench/compact_rivals.py" + "".join(" " + x for x in sys.argv[1:])
    t_start = time.time()
    out = []
    for mat in mats:
        t_mat = time.time()
        table = cm.Table(make_table(mat))
        hemi = table.domain == "hemisphere"
        asym = table.symmetric_in_phi()
        print("%s: %s, mirror asymmetry in phi_i %.2g%% of a slice's RGB L1 at most" % (mat, table.domain, 100 * asym),
              flush=True)
        q = queries(table, 20000)
        cand = {}  # representation -> list of (bytes, bytes_eval, config, stats, maker)

        # the mixture: per budget and K max, the most rows that fit (bytes per slice learnt from the fits)
        axis = [float(x) for x in table.theta_o]
        fits = {}
        per_slice = {}
        fixed = 8 * (len(axis) + 1)  # the table's theta_o and phi_o axes, float64

        def fitted(every, kmax):
            if (every, kmax) not in fits:
                r = fits[(every, kmax)] = fit_mixture(mat, table.path, axis, every, kmax)
                per_slice[kmax] = (r["bytes"] - fixed) / len(axis[::every])
                print("  mixture %s: %d B, median RGB %.2f%% (%.0f s)" % (
                    r["config"], r["bytes"], 100 * r["stats"]["median_rgb"], r["seconds"]), flush=True)
            return fits[(every, kmax)]

        def rows_for(b, kmax):
            n = max(2, int((b - fixed) / per_slice.get(kmax, GUESS[kmax])))
            return next(e for e in range(1, len(axis) + 1) if len(axis[::e]) <= n)

        for b in budgets:
            for kmax in K_MAX.get(b, (16,)):
                every = rows_for(b, kmax)
                for _ in range(3):
                    r = fitted(every, kmax)
                    better = rows_for(b, kmax)
                    if r["bytes"] > b:
                        every = max(every + 1, better)
                    elif better < every and (better, kmax) not in fits:
                        every = better
                    else:
                        break
        cand["mixture"] = [(r["bytes"], r["bytes_eval"], r["config"], r["stats"]["median_rgb"], ("mixture", r))
                           for r in fits.values()]

        # the rivals: every configuration screened on every 3rd table slice, the best under each budget
        # measured on all of them below
        screen = np.arange(1, len(axis), 3)
        for rep, with_cdf in (("table", True), ("table_eval", False)):
            cand[rep] = []
            for c in sorted({c for b in budgets for c in table_configs(b, with_cdf)}):
                grid, coarse = rival_table.downsample(table, *c)
                med = cm.summary(cm.slice_errors(table, rival_table.reconstruct(grid, coarse, screen), rows=screen))
                nb = rival_table.eval_bytes(*c) + (rival_table.cdf_bytes(*c) if with_cdf else 0)
                cand[rep].append((nb, rival_table.eval_bytes(*c), "%d x %d x %d (half of phi stored)" % c,
                                  med["median_rgb"], ("table", c)))
        shfit = rival_sh.Fit(table, L_MAX[table.domain], cosine=True)  # on the hemisphere f cos fits better than f
        for rep, with_cdf in (("sh", True), ("sh_eval", False)):
            cand[rep] = []
            for c in sorted({c for b in budgets for c in sh_configs(b, hemi, with_cdf)}):
                coef = shfit.coefficients(c[1], c[0])
                med = cm.summary(cm.slice_errors(table, shfit.reconstruct(coef, screen), rows=screen))
                eb = rival_sh.eval_bytes(c[0], c[1], hemi)
                nb = eb + (rival_sh.cdf_bytes(c[0], c[2]) if with_cdf else 0)
                cfg = "%d slices, l_max %d (%d coefficients)" % (c[0], c[1], rival_sh.count(c[1], hemi))
                if with_cdf:
                    cfg += ", CDF %d x %d" % (c[2], c[2])
                cand[rep].append((nb, eb, cfg, med["median_rgb"], ("sh", c)))

        # per budget, the best of each representation under it
        for b in budgets:
            picked = {}
            for rep, lst in cand.items():
                ok = [x for x in lst if x[0] <= b]
                if ok:
                    picked[rep] = min(ok, key=lambda x: x[3])
            evals = {}
            for rep, (nb, eb, cfg, _, maker) in picked.items():
                kind, c = maker
                if kind == "mixture":
                    st = c["stats"]
                elif kind == "table":
                    grid, coarse = rival_table.downsample(table, *c)
                    rgb_full = rival_table.reconstruct(grid, coarse)
                    st = cm.summary(cm.slice_errors(table, rgb_full))
                else:
                    coef = shfit.coefficients(c[1], c[0])
                    rgb_full = shfit.reconstruct(coef)
                    st = cm.summary(cm.slice_errors(table, rgb_full))
                row = dict(material=mat, domain=table.domain, representation=rep, budget=b, bytes=nb, bytes_eval=eb,
                           config=cfg.replace(",", ";"), median_l1=st["median_l1"], p90_l1=st["p90_l1"], median_rgb=st["median_rgb"],
                           p90_rgb=st["p90_rgb"], median_rgb_fitted=st.get("median_rgb_fitted", ""),
                           median_rgb_between=st.get("median_rgb_between", ""), max_energy=st["max_energy"], eval_ns="", relvar_median="",
                           relvar_p90="", missed_max="", relvar_uniform10_median="", relvar_uniform10_p90="",
                           slices=len(table.theta_o), phi_asymmetry=asym, fit_seconds="", cpu=cpu, cores=cores,
                           command=command)
                if kind == "mixture":
                    mix = mixture_eval.Mixtures(c["packed"])
                    rgb, y, p = mixture_eval.on_table(mix, table)
                    check = cm.summary(cm.slice_errors(table, rgb, y))
                    if abs(check["median_l1"] - st["median_l1"]) > 1e-4 or abs(check["median_rgb"] - st["median_rgb"]) > 1e-4:
                        sys.exit("%s %s: numpy stand-in median L1 %.6f / RGB %.6f, compare %.6f / %.6f" % (
                            mat, cfg, check["median_l1"], check["median_rgb"], st["median_l1"], st["median_rgb"]))
                    row["fit_seconds"] = c["seconds"]
                    evals[rep] = lambda mix=mix: mixture_points(mix, table, q)
                    keep_rgb = rgb
                elif kind == "table":
                    if rep == "table":
                        p = rival_table.probabilities(grid, coarse)
                    evals[rep] = lambda coarse=coarse: table_points(table, coarse, q)
                    keep_rgb = rgb_full
                else:
                    if rep == "sh":
                        p = rival_sh.cdf_probabilities(shfit, coef, c[2])
                    evals[rep] = lambda coef=coef, l=c[1]: sh_points(shfit, coef, l, q)
                    keep_rgb = rgb_full
                if rep in ("mixture", "table", "sh"):
                    rv, missed = cm.sampling_variance(table, p)
                    # with 10% uniform samples in solid angle, as mis_tab draws them at uniform_fraction 0.1
                    uni = table.solid_theta[:, None] * table.dph * np.ones(len(table.phi_i))[None]
                    rv10, _ = cm.sampling_variance(table, 0.9 * p + 0.1 * (uni / uni.sum())[None])
                    row.update(relvar_median=cm.quantile(rv, 0.5), relvar_p90=cm.quantile(rv, 0.9),
                               missed_max=float(np.max(missed)), relvar_uniform10_median=cm.quantile(rv10, 0.5),
                               relvar_uniform10_p90=cm.quantile(rv10, 0.9))
                if mat in keep and b == 8192 and rep in ("mixture", "table", "sh"):
                    table.write_like(os.path.join(WORK, "%s_%s_8k_table.h5" % (mat, rep)), keep_rgb, rep + " at 8 KiB: " + cfg)
                out.append(row)
            # evaluation cost, every representation of the budget in turn, best of 3
            for rep, fn in evals.items():
                ns = best_time(fn) / len(q[0]) * 1e9
                for row in out:
                    if row["material"] == mat and row["budget"] == b and row["representation"] == rep:
                        row["eval_ns"] = ns
                        row["eval_method"] = "header (module)" if rep == "mixture" else "numpy"
            print("  %5d B: %s" % (b, ", ".join("%s %.2f%% (%d B)" % (r["representation"], 100 * r["median_rgb"], r["bytes"])
                                               for r in out if r["material"] == mat and r["budget"] == b)), flush=True)
        print("  %s in %.0f s" % (mat, time.time() - t_mat), flush=True)
    os.makedirs(os.path.dirname(a.csv), exist_ok=True)
    with open(a.csv, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=COLUMNS, lineterminator="\n")
        w.writeheader()
        for r in out:
            w.writerow({k: ("%.6g" % v if isinstance(v, float) else v) for k, v in r.items()})
    if a.png:
        chart(out, a.png)
    print("total %.0f s; wrote %s%s" % (time.time() - t_start, a.csv, " and " + a.png if a.png else ""))


def chart(rows, png):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import FixedLocator, FuncFormatter, NullLocator
    mats = []
    for r in rows:
        if r["material"] not in mats:
            mats.append(r["material"])
    style = {"mixture": ("C3", "-", "o"), "table": ("C0", "-", "s"), "table_eval": ("C0", ":", "s"),
             "sh": ("C2", "-", "^"), "sh_eval": ("C2", ":", "^")}
    cols = 4
    nrow = (len(mats) + cols - 1) // cols
    fig, axes = plt.subplots(nrow, cols, figsize=(4 * cols, 3.4 * nrow), squeeze=False)
    ticks = [2048, 4096, 8192, 16384, 32768]
    for ax, mat in zip(axes.ravel(), mats):
        for rep, (c, ls, mk) in style.items():
            pts = sorted({int(r["bytes"]): float(r["median_rgb"]) for r in rows
                          if r["material"] == mat and r["representation"] == rep}.items())
            if pts:
                ax.plot([p[0] for p in pts], [100 * p[1] for p in pts], color=c, ls=ls, marker=mk, ms=4, label=rep)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.xaxis.set_major_locator(FixedLocator(ticks))
        ax.xaxis.set_minor_locator(NullLocator())
        ax.set_xticklabels(["%d KiB" % (t // 1024) for t in ticks])
        ax.set_xlim(1200, 40000)
        ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _: "%g" % v))
        ax.yaxis.set_minor_formatter(FuncFormatter(lambda v, _: "%g" % v if str("%g" % v)[0] in "1235" else ""))
        ax.set_title(mat, fontsize=10)
        ax.grid(alpha=0.3, which="both")
    for ax in axes.ravel()[len(mats):]:
        ax.axis("off")
    for ax in axes[:, 0]:
        ax.set_ylabel("median RGB error, % (log)")
    axes[0][0].legend(fontsize=7)
    fig.suptitle("error against bytes over every table slice (90 theta_o of 90 x 180); each point the best "
                 "configuration under its budget", fontsize=9)
    fig.tight_layout()
    os.makedirs(os.path.dirname(png), exist_ok=True)
    fig.savefig(png, dpi=110)


if __name__ == "__main__":
    main()
