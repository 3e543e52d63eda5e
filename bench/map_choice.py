#!/usr/bin/python3
"""fit.map auto against both fixed maps: the map it chooses and what the choice costs and gains.

Imports each shipped RGL file at the default grid (90 x 90 x 180) and fits every slice at the
default settings three times, with `fit.map: auto` (the default), `theta_phi` and `equal_area`
(docs/fitting.md, "The map"), each with /usr/bin/time-like wall seconds. Per fit, from its
report and its summary: the median, p90 and mean relative L1, the mean K, the map fitted, and
for auto the probe's seconds and its median L1 in each map. Tables and fits already in --work
are reused (their seconds with them).

    /usr/bin/python3 bench/map_choice.py [--bsdfmix build/bsdfmix] [--work out/map_choice] \
        [--materials ...] [--csv bench/results/map_choice.csv]
"""
import argparse
import json
import os
import re
import statistics

import study_io
from study_io import ROOT, rows as csv_rows

MAPS = ("auto", "theta_phi", "equal_area")


def fit(a, m, table, fit_map):
    """One fit's row: its errors from the report, its seconds and its summary's map line."""
    base = os.path.join(a.work, f"{m}_{fit_map}")
    mixture, report, summary = base + "_mixture.h5", base + "_fit.csv", base + "_summary.json"
    if not os.path.exists(summary):
        with open(base + ".yaml", "w") as f:
            f.write(f"table: {table}\nfit:\n  output: {mixture}\n  report: {report}\n"
                    f"  search_report: {base}_search.csv\n  map: {fit_map}\n")
        wall, cpu, _ = study_io.measured("map_choice", [study_io.BIN, "fit", base + ".yaml"], stdout=base + "_out.txt")
        text = open(base + "_out.txt").read()
        line = re.search(r"^  map +(.*)$", text, re.M)
        with open(summary + ".tmp", "w") as f:
            json.dump({"seconds": wall, "cpu_seconds": cpu, "map_line": line.group(1) if line else ""}, f)
        os.replace(summary + ".tmp", summary)
    s = json.load(open(summary))
    rep = csv_rows(report)
    l1 = sorted(float(r["l1_rel"]) for r in rep)
    probe = re.search(r"probe of (\d+) slice\(s\) in ([\d.]+) s: median L1 ([\d.]+)% on the disk, ([\d.]+)%",
                      s["map_line"])
    fitted = "disk" if (fit_map == "equal_area" or s["map_line"].startswith("the equal-area disk")) else "theta_phi"
    return {"table": m, "map": fit_map, "fitted": fitted, "slices": len(rep),
            "l1_median": f"{statistics.median(l1):.5f}", "l1_p90": f"{l1[round(0.9 * (len(l1) - 1))]:.5f}",
            "l1_mean": f"{statistics.mean(l1):.5f}",
            "mean_k": f"{statistics.mean(int(r['k']) for r in rep):.2f}",
            "fit_seconds": f"{s['seconds']:.1f}", "cpu_seconds": f"{s['cpu_seconds']:.1f}",
            "probe_slices": probe.group(1) if probe else "", "probe_seconds": probe.group(2) if probe else "",
            "probe_l1_disk": f"{float(probe.group(3)) / 100:.5f}" if probe else "",
            "probe_l1_theta_phi": f"{float(probe.group(4)) / 100:.5f}" if probe else ""}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bsdfmix", default=study_io.BIN)
    ap.add_argument("--work", default=os.path.join(ROOT, "out", "map_choice"))
    ap.add_argument("--materials", default="", help="RGL names (data/rgl/NAME_rgb.bsdf), comma-separated; default all")
    ap.add_argument("--csv", default=os.path.join(ROOT, "bench", "results", "map_choice.csv"))
    a = ap.parse_args()
    study_io.BIN = a.bsdfmix
    os.makedirs(a.work, exist_ok=True)
    materials = study_io.rgl_materials(a.materials)
    out = []
    for m in materials:
        table = os.path.join(a.work, m + "_table.h5")
        if not os.path.exists(table):
            study_io.bsdfmix("map_choice", "import", "rgl", "-q", os.path.join(ROOT, "data", "rgl", m + "_rgb.bsdf"),
                             "-o", table)
        for fit_map in MAPS:
            out.append(fit(a, m, table, fit_map))
            r = out[-1]
            print(f"{m} {fit_map}: {r['fitted']}, median L1 {100 * float(r['l1_median']):.2f}%, "
                  f"p90 {100 * float(r['l1_p90']):.2f}%, {r['fit_seconds']} s")
    os.makedirs(os.path.dirname(os.path.abspath(a.csv)), exist_ok=True)
    study_io.write_rows(a.csv, out)
    print(a.csv)


if __name__ == "__main__":
    main()
