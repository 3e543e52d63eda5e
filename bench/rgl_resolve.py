#!/usr/bin/python3
"""Sharp lobes resolved: each shipped RGL material imported at the default grid and at the
grid `bsdfmix import rgl --resolve` chooses (the file's narrowest lobe spans 3 cells), fitted
at the slices serving a few random view elevations, at the default settings and (the resolved
grid) also to a relative L1 error of 2 % (fit.error_target 0.02), and
each mixture measured as a sampler against the file's own (`bsdfmix bench sampling`, f the
file's evaluation): the variance per sample over the RGL sampler's, with the bytes of the
table and of the mixture.

    /usr/bin/python3 bench/rgl_resolve.py [--directions 8] [--samples 16384]
        [--materials satin_rosaline,...] [--max-mib 400] [--csv bench/results/rgl_resolve.csv]

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

import numpy as np
from machine import cpu_model  # noqa: E402  (bench/machine.py)
from study_io import BIN, ROOT, by_view, bsdfmix, over_rgl, rows, write_rows  # noqa: E402  (bench/study_io.py)

VIEW_STREAM = 0x76696577  # bench/sampling_peers.cpp kViewStream


def run(*args):
    bsdfmix("rgl_resolve", *args)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--work", default=os.path.join(ROOT, "out", "rgl_resolve"))
    ap.add_argument("--directions", type=int, default=8)
    ap.add_argument("--samples", type=int, default=16384)
    ap.add_argument("--materials", default="")
    ap.add_argument("--max-mib", type=float, default=400)
    ap.add_argument("--csv", default=os.path.join(ROOT, "bench", "results", "rgl_resolve.csv"))
    a = ap.parse_args()
    os.makedirs(a.work, exist_ok=True)
    want = set(filter(None, a.materials.split(",")))
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
        # (kind, table, extra fit settings): the default grid, the resolved one, and the resolved
        # one fitted to a relative L1 error of 2 % (fit.error_target) instead of the K penalty
        tables = [("default", default_table, "")]
        if table_mib <= a.max_mib:
            resolved = base + "_resolved.h5"
            if not os.path.exists(resolved):
                run("import", "rgl", "-q", rgl, "--resolve", "-o", resolved)
            tables += [("resolved", resolved, ""), ("resolved_t2", resolved, "  error_target: 0.02\n")]
        for kind, table, extra in tables:
            mixture = f"{base}_{kind}_mixture.h5"
            if not os.path.exists(mixture):
                # only the slices serving the study's view elevations are fitted
                vs = view_elevations(a.directions)
                cfg = f"{base}_{kind}.yaml"
                with open(cfg, "w") as f:
                    f.write(f"table: {table}\nfit:\n  output: {mixture}\n  report: {base}_{kind}_fit.csv\n"
                            f"  search_report: {base}_{kind}_search.csv\n"
                            f"  theta_o: [{', '.join(f'{v:.6f}' for v in vs)}]\n{extra}")
                run("fit", "-q", cfg)
            smp = f"{base}_{kind}_sampling.csv"
            run("bench", "sampling", "-q", "--rgl", rgl, "--table", table, "--mixture", mixture, "--directions",
                str(a.directions), "--samples", str(a.samples), "--seed", "1", "--csv", smp)
            by = by_view(smp)
            ratio, cdf = over_rgl(by, "is_mixture"), over_rgl(by, "cdf_table")
            any_row = next(iter(by.values()))
            res = kind != "default"
            fit_rows = rows(f"{base}_{kind}_fit.csv")
            l1 = [float(r["l1_rel"]) for r in fit_rows if r.get("l1_rel")]
            out.append({"material": name, "grid": kind, "theta_o": grid[0] if res else 90,
                        "theta_i": grid[1] if res else 90, "phi_i": grid[2] if res else 180,
                        "error_target": "0.02" if extra else "", "fit_l1_median": f"{np.median(l1):.4f}" if l1 else "",
                        "lobe_fwhm_theta_deg": fwhm_t, "lobe_fwhm_across_deg": fwhm_x, "lobe_at_theta_o_deg": at,
                        "table_mib": f"{(grid[0] * grid[1] * grid[2] if res else 90 * 90 * 180) * 16 / 2**20:.1f}",
                        "mixture_bytes": any_row["is_mixture"]["bytes"], "views": len(ratio), "samples": a.samples,
                        "is_mixture_over_rgl_median": f"{np.median(ratio):.4g}",
                        "is_mixture_over_rgl_max": f"{np.max(ratio):.4g}",
                        "cdf_table_over_rgl_median": f"{np.median(cdf):.4g}",
                        "cdf_table_over_rgl_max": f"{np.max(cdf):.4g}", "cpu": cpu_model()})
            print(", ".join(f"{k} {v}" for k, v in out[-1].items() if k != "cpu"), flush=True)
        if not any(kind == "resolved" for kind, _, _ in tables):
            out.append({"material": name, "grid": "resolved", "theta_o": grid[0], "theta_i": grid[1], "phi_i": grid[2],
                        "error_target": "", "fit_l1_median": "",
                        "lobe_fwhm_theta_deg": fwhm_t, "lobe_fwhm_across_deg": fwhm_x, "lobe_at_theta_o_deg": at,
                        "table_mib": f"{table_mib:.1f}", "mixture_bytes": "", "views": 0, "samples": 0,
                        "is_mixture_over_rgl_median": "", "is_mixture_over_rgl_max": "",
                        "cdf_table_over_rgl_median": "", "cdf_table_over_rgl_max": "", "cpu": cpu_model()})
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
