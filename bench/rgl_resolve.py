#!/usr/bin/python3
"""Sharp lobes resolved: each shipped RGL material imported at the default grid and at the
grid `bsdfmix import rgl --resolve` chooses (the file's narrowest lobe spans 3 cells), fitted
at the slices serving random view elevations (those of `bench sampling --directions`), at the
default settings and (the resolved grid) also to a relative L1 error of 2 % (fit.error_target
0.02), and each mixture measured as a sampler against the file's own (`bsdfmix bench
sampling`, f the file's evaluation): the variance per sample over the RGL sampler's, with the
bytes of the table and of the mixture, the fit's wall time, the views over 3x and the table CDF's ratio at the
mixture's worst view.

The --probe materials also get the resolved grid, fitted to 2 % L1, with one thing more
each: twice the theta_o slices, four times the theta_i cells, phi_i at its cap (1440), or K up
to 64: what the worst (grazing) views are limited by.

    /usr/bin/python3 bench/rgl_resolve.py [--directions 20] [--samples 16384]
        [--materials satin_rosaline,...] [--probe satin_rosaline] [--max-mib 400]
        [--grids default,resolved,resolved_t2] [--csv bench/results/rgl_resolve.csv]

--grids keeps only the rows named (the probes run with resolved_t2).

A material whose resolved table would exceed --max-mib is reported with its grid and bytes
and not imported.
"""
import argparse
import glob
import math
import os
import re
import subprocess
import sys
import time

import numpy as np
from machine import cpu_model  # noqa: E402  (bench/machine.py)
from study_io import BIN, ROOT, by_view, bsdfmix, over_rgl, rows, write_rows  # noqa: E402  (bench/study_io.py)

VIEW_STREAM = 0x76696577  # bench/sampling_peers.cpp kViewStream


def run(*args):
    bsdfmix("rgl_resolve", *args)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--work", default=os.path.join(ROOT, "out", "rgl_resolve"))
    ap.add_argument("--directions", type=int, default=20)
    ap.add_argument("--samples", type=int, default=16384)
    ap.add_argument("--materials", default="")
    ap.add_argument("--probe", default="satin_rosaline")
    ap.add_argument("--max-mib", type=float, default=400)
    ap.add_argument("--grids", default="default,resolved,resolved_t2")
    ap.add_argument("--csv", default=os.path.join(ROOT, "bench", "results", "rgl_resolve.csv"))
    a = ap.parse_args()
    grids = set(filter(None, a.grids.split(",")))
    os.makedirs(a.work, exist_ok=True)
    want = set(filter(None, a.materials.split(",")))
    probe_set = set(filter(None, a.probe.split(",")))
    out = []
    for rgl in sorted(glob.glob(os.path.join(ROOT, "data", "rgl", "*_rgb.bsdf"))):
        name = os.path.basename(rgl).replace("_rgb.bsdf", "")
        if want and name not in want:
            continue
        base = os.path.join(a.work, name)
        default_table = base + "_default.h5"
        if not os.path.exists(default_table):
            run("import", "rgl", "-q", rgl, "-o", default_table)
        # the rule's lobe and grid at the default floors: the log line a resolved import prints
        # before it tabulates (the import itself is stopped there)
        probe = subprocess.Popen([BIN, "import", "rgl", rgl, "--resolve", "-o", base + "_probe.h5"],
                                 stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True)
        line = probe.stderr.readline()
        probe.kill()
        probe.wait()
        for p in glob.glob(base + "_probe.h5*"):
            os.remove(p)
        m = re.search(r"narrowest lobe ([\d.]+) x ([\d.]+) degrees .* at theta_o ([\d.]+) degrees", line)
        if not m:
            sys.exit(f"rgl_resolve: {rgl}: no lobe line from `import rgl --resolve`: {line.strip()}")
        fwhm_t, fwhm_x, at = float(m.group(1)), float(m.group(2)), float(m.group(3))
        g = re.search(r"grid (\d+) x (\d+) x (\d+)", line)
        grid = tuple(int(x) for x in g.groups())
        table_mib = grid[0] * grid[1] * grid[2] * 16 / 2**20
        # (kind, table, grid, k_max): the default grid, the resolved one, the resolved one fitted
        # to a relative L1 error of 2 % (fit.error_target) instead of the K penalty, and (--probe)
        # that fit with a finer grid along one axis or more components
        tables = [("default", default_table, (90, 90, 180), 32)] if "default" in grids else []
        if table_mib <= a.max_mib:
            resolved = base + "_resolved.h5"
            if not os.path.exists(resolved):
                run("import", "rgl", "-q", rgl, "--resolve", "-o", resolved)
            tables += [(kind, resolved, grid, 32) for kind in ("resolved", "resolved_t2") if kind in grids]
            if name in probe_set and "resolved_t2" in grids:
                finer = {"resolved_t2_theta_o_x2": (2 * grid[0], grid[1], grid[2]),
                         "resolved_t2_theta_i_x4": (grid[0], 4 * grid[1], grid[2]),
                         "resolved_t2_phi_i_1440": (grid[0], grid[1], 1440)}
                for kind, g in finer.items():
                    table = f"{base}_{kind}.h5"
                    if not os.path.exists(table):
                        run("import", "rgl", "-q", rgl, "--theta-o", str(g[0]), "--theta-i", str(g[1]),
                            "--phi-i", str(g[2]), "-o", table)
                    tables.append((kind, table, g, 32))
                tables.append(("resolved_t2_k64", resolved, grid, 64))
        for kind, table, g, k_max in tables:
            extra = ("  error_target: 0.02\n" if kind.startswith("resolved_t2") else "") + \
                    (f"  k_max: {k_max}\n" if k_max != 32 else "")
            mixture = f"{base}_{kind}_mixture.h5"
            # only the slices serving the study's view elevations are fitted; a mixture made by
            # another config (other views or settings) is fitted again, one of this config kept
            vs = view_elevations(a.directions)
            cfg = f"{base}_{kind}.yaml"
            text = (f"table: {table}\nfit:\n  output: {mixture}\n  report: {base}_{kind}_fit.csv\n"
                    f"  search_report: {base}_{kind}_search.csv\n"
                    f"  theta_o: [{', '.join(f'{v:.6f}' for v in vs)}]\n{extra}")
            old = open(cfg).read() if os.path.exists(cfg) else None
            smp = f"{base}_{kind}_sampling.csv"
            fit_seconds = f"{base}_{kind}_fit_seconds.txt"  # the wall time of the fit run that finished it
            if old != text:
                for p in (mixture, smp, f"{base}_{kind}_fit.csv", f"{base}_{kind}_search.csv", fit_seconds):
                    if os.path.exists(p):
                        os.remove(p)
                with open(cfg + ".tmp", "w") as f:
                    f.write(text)
                os.replace(cfg + ".tmp", cfg)
            if not os.path.exists(mixture):  # a fit killed before it wrote the mixture resumes
                t0 = time.monotonic()
                run("fit", "-q", cfg)
                with open(fit_seconds + ".tmp", "w") as f:
                    f.write(f"{time.monotonic() - t0:.1f}\n")
                os.replace(fit_seconds + ".tmp", fit_seconds)
            by = by_view(smp) if os.path.exists(smp) else {}
            if len(by) != a.directions or any(r["samples"] != str(a.samples) for v in by.values() for r in v.values()):
                run("bench", "sampling", "-q", "--rgl", rgl, "--table", table, "--mixture", mixture, "--directions",
                    str(a.directions), "--samples", str(a.samples), "--seed", "1", "--csv", smp)
                by = by_view(smp)
            # else: measured by an earlier run of this config
            ratio, cdf = over_rgl(by, "is_mixture"), over_rgl(by, "cdf_table")
            views = list(by.keys())
            worst = int(np.argmax(ratio))
            any_row = next(iter(by.values()))
            fit_rows = rows(f"{base}_{kind}_fit.csv")
            l1 = [float(r["l1_rel"]) for r in fit_rows if r.get("l1_rel")]
            out.append({"material": name, "grid": kind, "theta_o": g[0], "theta_i": g[1], "phi_i": g[2],
                        "error_target": "0.02" if "error_target" in extra else "", "k_max": k_max,
                        "fit_l1_median": f"{np.median(l1):.4f}" if l1 else "",
                        "fit_seconds": open(fit_seconds).read().strip() if os.path.exists(fit_seconds) else "",
                        "lobe_fwhm_theta_deg": fwhm_t, "lobe_fwhm_across_deg": fwhm_x, "lobe_at_theta_o_deg": at,
                        "table_mib": f"{g[0] * g[1] * g[2] * 16 / 2**20:.1f}",
                        "mixture_bytes": any_row["is_mixture"]["bytes"], "views": len(ratio), "samples": a.samples,
                        "is_mixture_over_rgl_median": f"{np.median(ratio):.4g}",
                        "is_mixture_over_rgl_max": f"{np.max(ratio):.4g}",
                        "cdf_table_over_rgl_median": f"{np.median(cdf):.4g}",
                        "cdf_table_over_rgl_max": f"{np.max(cdf):.4g}",
                        "views_over_3x": sum(x > 3 for x in ratio), "worst_view_deg": f"{float(views[worst]):.1f}",
                        "cdf_table_over_rgl_at_worst": f"{cdf[worst]:.4g}", "cpu": cpu_model()})
            print(", ".join(f"{k} {v}" for k, v in out[-1].items() if k != "cpu"), flush=True)
        if table_mib > a.max_mib:
            out.append({"material": name, "grid": "resolved", "theta_o": grid[0], "theta_i": grid[1], "phi_i": grid[2],
                        "error_target": "", "k_max": 32, "fit_l1_median": "", "fit_seconds": "",
                        "lobe_fwhm_theta_deg": fwhm_t, "lobe_fwhm_across_deg": fwhm_x, "lobe_at_theta_o_deg": at,
                        "table_mib": f"{table_mib:.1f}", "mixture_bytes": "", "views": 0, "samples": 0,
                        "is_mixture_over_rgl_median": "", "is_mixture_over_rgl_max": "",
                        "cdf_table_over_rgl_median": "", "cdf_table_over_rgl_max": "",
                        "views_over_3x": "", "worst_view_deg": "", "cdf_table_over_rgl_at_worst": "", "cpu": cpu_model()})
            print(f"{name}: the resolved grid {grid} needs {table_mib:.0f} MiB (over --max-mib): not imported", flush=True)
    write_rows(a.csv, out)


def view_elevations(directions, theta_max_deg=85.0, seed=1):
    """bench sampling's view elevations (study_directions): u0 of Philox sample i of the view stream."""
    sys.path.insert(0, os.path.join(ROOT, "scripts"))
    import bsdfmix_import  # noqa: E402
    bsdfmix = bsdfmix_import.load()
    u = np.asarray(bsdfmix.uniforms(seed, VIEW_STREAM, directions))
    return [float(x) * math.radians(theta_max_deg) for x in u[:, 0]]


if __name__ == "__main__":
    main()
