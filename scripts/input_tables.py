#!/usr/bin/python3
"""The doc tables of the input tables' own accuracy (scripts/doc_tables.py calls these):

  fiber_quadrature  bench/results/fiber_quadrature.csv (docs/studies/fiber_quadrature.md)
  fiber_generate    bench/results/fiber_generate.csv (docs/fiber.md, the generator's time and memory)
  cells_scale       bench/results/cells_scale.csv (docs/studies/cells_scale.md): fit time per cell and
                    peak memory by table size
  rgl_albedo        bench/results/rgl_albedo.csv (docs/studies/rgl_albedo.md): the albedo on the
                    default grid and sampled, their difference to the converged midpoint rule,
                    and the reciprocity
"""
import collections
import functools

from readme_measured import pct, rows

PRESETS = ("polyester", "silk", "cotton", "wool")
FILES = ("cg_sunflower_rgb", "paper_white_rgb", "satin_rosaline_rgb", "cc_iris_purple_gem_rgb")
ANGLES = ("0", "45", "75", "85")


def sci(x):
    m, e = ("%.1e" % float(x)).split("e")
    return "%se%d" % (m, int(e))


def fiber_quadrature():
    by = {(r["preset"], r["nodes"]): r["max_rel_error"] for r in rows("fiber_quadrature.csv")}
    nodes = sorted({int(n) for _, n in by}, key=int)
    out = ["| nodes | " + " | ".join(PRESETS) + " |", "|---" * (len(PRESETS) + 1) + "|"]
    for n in nodes:
        out.append("| %d | " % n + " | ".join(sci(by[(p, str(n))]) for p in PRESETS) + " |")
    return out


@functools.lru_cache(maxsize=None)
def _albedo():
    """rgl_albedo.csv by (file, quantity), then theta_o in degrees (read once for the three tables)."""
    a = collections.defaultdict(dict)
    for r in rows("rgl_albedo.csv"):
        a[(r["file"], r["quantity"])][r["theta_o_deg"]] = float(r["value"])
    return a


def rgl_albedo():
    a = _albedo()
    out = ["| file (grid / sampled) | " + " | ".join(ANGLES) + " | max up to 75 |", "|---" * (len(ANGLES) + 2) + "|"]
    for f in FILES:
        g, s = a[(f, "albedo_grid")], a[(f, "albedo_sampled")]
        up75 = [d for d in g if d != "" and int(d) <= 75]
        cells = ["%.3f / %.3f" % (g[d], s[d]) for d in ANGLES]
        cells.append("%.3f / %.3f" % (max(g[d] for d in up75), max(s[d] for d in up75)))
        out.append("| %s | %s |" % (f.replace("_rgb", ""), " | ".join(cells)))
    return out


def rgl_grid_error():
    a = _albedo()
    out = ["| file (grid / sampled, against 1440 x 2880 cells) | " + " | ".join(ANGLES) + " | converged albedo at 75 |",
           "|---" * (len(ANGLES) + 2) + "|"]
    for f in FILES:
        g, s, c = a[(f, "albedo_grid")], a[(f, "albedo_sampled")], a[(f, "albedo_fine")]
        cells = ["%s / %s" % (pct(g[d] / c[d] - 1, 1), pct(s[d] / c[d] - 1, 1)) for d in ANGLES]
        out.append("| %s | %s | %.4f |" % (f.replace("_rgb", ""), " | ".join(cells), c["75"]))
    return out


def rgl_reciprocity():
    a = _albedo()
    out = ["| file | median | 90th percentile | weighted by f |", "|---|---|---|---|"]
    for f in FILES:
        out.append("| %s | %s | %s | %s |" % (f.replace("_rgb", ""), pct(a[(f, "reciprocity_median")][""], 1),
                                              pct(a[(f, "reciprocity_p90")][""], 1),
                                              pct(a[(f, "reciprocity_weighted")][""], 1)))
    return out


def fiber_generate():
    names = {"default": "default, 180 x 90 x 180 (one phi_o by symmetry)",
             "full_4d": "90 x 180 x 90 x 180 without symmetry, noise on"}
    out = ["| table | file | time | peak memory |", "|---|---|---|---|"]
    for r in rows("fiber_generate.csv"):
        b = int(r["bytes"])
        size = "%.1f GB" % (b / 1e9) if b >= 1e9 else "%.0f MB" % (b / 1e6)
        t = float(r["seconds_best"])
        out.append("| %s | %s | %s s%s | %s MB |" % (names.get(r["table"], r["table"]), size,
                                                  "%.2f" % t if t < 10 else "%.0f" % t,
                                                  " (best of %s)" % r["runs"] if int(r["runs"]) > 1 else "",
                                                  r["peak_rss_mb"]))
    return out


CELLS_NAMES = {"full_4d": "90 x 180 x 90 x 180"}


def cells_scale():
    """Per table size: the fit's wall and CPU time per cell, cores kept busy, peak memory (the build
    before's beside, where the CSV has it). A row fitted part way says how much."""
    out = ["| table | cells | slices | wall time | ns per cell: wall / CPU | CPU use | peak memory | "
           "before this change |", "|---|---|---|---|---|---|---|---|"]
    before = {r["table"]: r for r in rows("cells_scale.csv") if r["build"] == "before"}
    for r in rows("cells_scale.csv"):
        if r["build"] != "this":
            continue
        part = "" if r["cells_fitted"] == r["cells"] else " (%.0f%% fitted)" % (
            100.0 * int(r["cells_fitted"]) / int(r["cells"]))
        runs = " (best of %s)" % r["runs"] if int(r["runs"]) > 1 else ""
        b = before.get(r["table"])
        out.append("| %s | %.2g | %s | %.0f s%s%s | %.0f / %.0f | %.0f%% | %s MiB | %s |" % (
            CELLS_NAMES.get(r["table"], r["table"]), int(r["cells"]), r["slices"], float(r["wall_s"]), runs, part,
            float(r["ns_per_cell"]), float(r["cpu_ns_per_cell"]), 100 * float(r["cpu_utilization"]),
            r["peak_rss_mib"], "%s MiB" % b["peak_rss_mib"] if b else "-"))
    return out
