#!/usr/bin/python3
"""How small a stand-in can be: bytes against error, on the shipped RGL materials or any input.

For each input (default: --materials, data/rgl/<name>_rgb.bsdf): an RGL file (.bsdf) is imported at
30 theta_o x 90 x 180 (or --rows theta_o); a table (.h5) is used at its own grid. Then: fit stand-ins
on every 1st, 2nd and 4th table theta_o row from the first (`fit.theta_o_rows`) at
K max 4, 8, 16 (the fit settings of configs/converge_light_satin.yaml otherwise), pack each fit in
every storage (padded / ragged, rgb_scale float64 / float32), compare each with its table at every
table slice, and write bench/results/stand_in_bytes.csv (its `grid` column: theta_o x theta_i x
phi_i) and docs/images/stand_in_bytes.png.

    /usr/bin/python3 bench/stand_in_bytes.py [INPUT.bsdf|TABLE.h5 ...] [--materials a,b] [--steps 1,2,4]
                                             [--kmax 4,8,16] [--rows 30] [--csv F] [--png P, "" for none]

Storage does not change the mixtures (float32 rounding of rgb_scale aside), so each fit
is compared once per rgb precision; padded and ragged files of one precision hold the
same mixtures and share the comparison (the CSV row says which file was compared).
"""
import argparse
import csv
import os
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BIN = os.path.join(ROOT, "build", "bsdfmix")
WORK = os.path.join(ROOT, "out", "stand_in_bytes")
STORAGES = ["padded", "ragged", "padded_f32", "ragged_f32"]


def run(cmd):
    r = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit("failed: %s\n%s%s" % (" ".join(cmd), r.stdout, r.stderr))
    return r.stdout


def table_grid(path):
    """The table's theta_o rows and its grid as "theta_o x theta_i x phi_i"."""
    import h5py
    with h5py.File(path, "r") as f:
        t = f["table"]
        rows = [float(x) for x in t["theta_o"][()]]
        return rows, "%dx%dx%d" % (len(rows), len(t["theta_i"]), len(t["phi_i"]))


def inputs(a):
    """(name, table path) per input: RGL files imported into WORK, tables as they are."""
    paths = a.inputs or [os.path.join(ROOT, "data", "rgl", m + "_rgb.bsdf") for m in a.materials.split(",")]
    out = []
    for p in paths:
        name = os.path.basename(p).rsplit(".", 1)[0]
        if not p.endswith(".bsdf"):
            out.append((name, p))
            continue
        name = name[:-4] if name.endswith("_rgb") else name
        table = os.path.join(WORK, "%s_table%s.h5" % (name, "" if a.rows == 30 else "_%d" % a.rows))
        if not os.path.exists(table):
            run([BIN, "import", "rgl", p, "--theta-o", str(a.rows), "--theta-i", "90", "--phi-i", "180", "-o", table,
                 "--quiet"])
        out.append((name, table))
    return out


def compare_stats(csv_path):
    rows = list(csv.DictReader(open(csv_path)))
    import numpy as np
    # rgb_negative_share is the share of rgb_error in cells where the table is negative
    # (docs/formats.md, "Compare"): the error less it is rgb_error (1 - share).
    err = np.array([float(r["rgb_error"]) * (1 - float(r["rgb_negative_share"])) for r in rows])
    l1 = np.array([float(r["l1_rel"]) for r in rows])
    # a channel of noise around zero (the `noise` column) has no integral the stand-in keeps
    energy = [abs(float(r[c])) for r in rows for c in r
              if c.startswith("energy") and not (c[-2] == "_" and c[-1] in r.get("noise", ""))]
    return dict(slices=len(rows), median_rgb=float(np.median(err)), p90_rgb=float(np.percentile(err, 90)),
                median_l1=float(np.median(l1)), max_energy=max(energy) if energy else float("nan"))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("inputs", nargs="*", help="RGL files (.bsdf, imported at --rows) or tables (.h5)")
    ap.add_argument("--materials", default="satin_rosaline,paper_white,cg_sunflower")
    ap.add_argument("--steps", default="1,2,4")
    ap.add_argument("--kmax", default="4,8,16")
    ap.add_argument("--rows", type=int, default=30, help="theta_o rows of the imported tables")
    ap.add_argument("--csv", default=os.path.join(ROOT, "bench", "results", "stand_in_bytes.csv"))
    ap.add_argument("--png", default=os.path.join(ROOT, "docs", "images", "stand_in_bytes.png"))
    ap.add_argument("--chart-only", action="store_true", help="redraw the chart from --csv")
    a = ap.parse_args()
    if a.chart_only:
        rows = list(csv.DictReader(open(a.csv)))
        for r in rows:
            for k in ("bytes", "every", "k_max"):
                r[k] = int(r[k])
            r["median_rgb_error"] = float(r["median_rgb_error"])
        chart(rows, a.png)
        return
    os.makedirs(WORK, exist_ok=True)
    cpu = subprocess.run("lscpu | grep 'Model name'", shell=True, capture_output=True, text=True).stdout
    cpu = cpu.split(":", 1)[-1].strip().replace(",", ";")
    cores = os.cpu_count()
    t_start = time.time()
    out = []
    for mat, table in inputs(a):
        axis, grid = table_grid(table)
        for step in [int(x) for x in a.steps.split(",")]:
            chosen = list(range(0, len(axis), step))  # the last row only when the step lands on it
            n_fitted = len(chosen)
            for kmax in [int(x) for x in a.kmax.split(",")]:
                stem = os.path.join(WORK, "%s_%s_s%d_k%d" % (mat, grid, step, kmax))
                mixture = stem + ".h5"
                cfg = stem + ".yaml"
                with open(cfg, "w") as f:  # converge_light_satin.yaml's fit, but k_max and theta_o
                    f.write("table: %s\nfit:\n  output: %s\n  report: %s_fit.csv\n  search_report: %s_search.csv\n"
                            "  k_min: 1\n  k_max: %d\n  seed: 1\n  theta_o_rows: [%s]\n"
                            % (table, mixture, stem, stem, kmax, ", ".join(map(str, chosen))))
                t0 = time.time()
                if not os.path.exists(mixture):  # a cached fit keeps the seconds it took
                    run([BIN, "fit", cfg, "--quiet"])
                    fitted = len(list(csv.DictReader(open(stem + "_fit.csv"))))
                    if fitted != n_fitted:
                        sys.exit("%s: %d slices fitted for %d planned" % (cfg, fitted, n_fitted))
                    with open(stem + ".seconds", "w") as f:
                        f.write("%.1f\n" % (time.time() - t0))
                fit_s = float(open(stem + ".seconds").read()) if os.path.exists(stem + ".seconds") else float("nan")
                stats = {}
                for st in STORAGES:
                    packed = "%s_%s.h5" % (stem, st)
                    line = run([BIN, "pack", mixture, "-o", packed, "--storage", st, "--quiet"])
                    payload = int(line.rsplit("->", 1)[1].split()[0])
                    prec = st.endswith("_f32")
                    if prec not in stats:  # padded and ragged hold the same mixtures
                        cmp_csv = packed[:-3] + "_compare.csv"
                        run([BIN, "compare", packed, table, "--csv", cmp_csv, "--quiet"])
                        stats[prec] = compare_stats(cmp_csv)
                    s = stats[prec]
                    out.append(dict(material=mat, grid=grid, rows=len(axis), slices_fitted=n_fitted, every=step, k_max=kmax, storage=st,
                                    bytes=payload, file_bytes=os.path.getsize(packed),
                                    median_rgb_error=s["median_rgb"], p90_rgb_error=s["p90_rgb"],
                                    median_l1=s["median_l1"], max_energy_error=s["max_energy"],
                                    slices_compared=s["slices"], fit_seconds=round(fit_s, 1), cpu=cpu, cores=cores))
                print("%s every %d k_max %d: %d B ragged_f32, median rgb error %.4f (%.0f s)"
                      % (mat, step, kmax, out[-1]["bytes"], stats[True]["median_rgb"], fit_s), flush=True)
    os.makedirs(os.path.dirname(a.csv), exist_ok=True)
    with open(a.csv, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(out[0].keys()), lineterminator="\n")
        w.writeheader()
        for r in out:
            w.writerow({k: ("%.6g" % v if isinstance(v, float) else v) for k, v in r.items()})
    if a.png:
        chart(out, a.png)
    print("total %.0f s; wrote %s and %s" % (time.time() - t_start, a.csv, a.png))


def chart(rows, png):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    mats = sorted(set(r["material"] for r in rows), key=[r["material"] for r in rows].index)
    fig, axes = plt.subplots(1, len(mats), figsize=(5 * len(mats), 4.2), sharey=True, squeeze=False)
    marks = {"padded": "s", "ragged": "o", "padded_f32": "D", "ragged_f32": "^"}
    anchors = [(16 * 1024, "RGL format, 1 channel\n(Dupuy & Jakob, ~16 KiB)"), (48 * 1024, "RGL format, RGB (~48 KiB)"),
               (2700, "neural BRDF\n(Sztrajman et al. 2021, ~2.7 KB)")]
    for ax, mat in zip(axes[0], mats):
        for st in marks:
            pts = [r for r in rows if r["material"] == mat and r["storage"] == st]
            ax.scatter([r["bytes"] for r in pts], [100 * r["median_rgb_error"] for r in pts], marker=marks[st],
                       s=22, label=st, alpha=0.8)
        best = [r for r in rows if r["material"] == mat and r["storage"] == "ragged_f32"]
        for r in best:
            ax.annotate("1/%d k%d" % (r["every"], r["k_max"]), (r["bytes"], 100 * r["median_rgb_error"]), fontsize=6,
                        xytext=(3, 3), textcoords="offset points")
        for x, label in anchors:
            ax.axvline(x, color="grey", ls=":", lw=1)
            ax.text(x, 0.98, label, rotation=90, va="top", ha="right", fontsize=6, transform=ax.get_xaxis_transform())
        ax.axvspan(644 * 1024, 1030 * 1024, color="grey", alpha=0.15)
        ax.text(800 * 1024, 0.98, "shipped .bsdf\n644-1030 KiB", rotation=90, va="top", ha="center", fontsize=6,
                transform=ax.get_xaxis_transform())
        ax.axhline(5, color="red", lw=0.8, ls="--")
        ax.set_ylim(bottom=0)
        ax.set_xscale("log")
        ax.set_xlim(1000, 2e6)
        ax.set_title(mat)
        ax.set_xlabel("payload bytes (log)")
        ax.grid(alpha=0.3)
    axes[0][0].set_ylabel("median RGB error (less negative share), %")
    grids = ", ".join(sorted(set(r.get("grid") or "%sx90x180" % r["rows"] for r in rows)))
    fig.suptitle("stand-in bytes against error over every table slice, grid %s (theta_o x theta_i x phi_i; "
                 "label: rows fitted 1/n, K max)" % grids, fontsize=9)
    axes[0][-1].legend(fontsize=7, loc="upper right")
    fig.tight_layout()
    os.makedirs(os.path.dirname(png), exist_ok=True)
    fig.savefig(png, dpi=130)


if __name__ == "__main__":
    main()
