"""bench/results/render_4d.csv as docs/studies/render_4d.md's table (`render_4d`, by scripts/doc_tables.py)
and the README's row: f from the full-4D table, memory-mapped, against its stand-in."""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from readme_measured import link, rows, times  # noqa: E402

LABELS = {("full_4d", "table"): "full-4D table, mapped", ("full_4d", "stand_in"): "its stand-in",
          ("azimuthal", "table"): "azimuthal table, in memory", ("azimuthal", "stand_in"): "its stand-in"}


def size(b):
    b = float(b)
    for unit, n in (("GiB", 2 ** 30), ("MiB", 2 ** 20), ("KiB", 2 ** 10)):
        if b >= 0.9 * n:
            return "%.3g %s" % (b / n, unit)
    return "%d B" % b


def by():
    return {(r["table"], r["f"]): r for r in rows("render_4d.csv")}


def table():
    out = ["| f | ns per vertex | memory of f | peak RSS of the render | relative MSE against the reference |",
           "|---|---|---|---|---|"]
    for key, label in LABELS.items():
        r = by()[key]
        if key[1] == "stand_in":
            mem = size(r["mixture_bytes"])
        elif r["mapped_bytes"]:
            mem = "%s mapped (`values` %s), %s resident" % (
                size(r["mapped_bytes"]), size(r["table_bytes"]), size(r["resident_bytes"]))
        else:
            mem = size(r["table_bytes"])
        out.append("| %s | %s | %s | %s | %.3g |" % (label, r["ns_per_vertex_best"], mem, size(r["peak_rss_bytes"]),
                                                    float(r["rel_mse_vs_reference"])))
    return out


def ratios():
    """ns per vertex of the mapped table over the stand-in's, and the table's cell bytes and
    resident bytes over the stand-in's bytes."""
    b = by()
    t, s = b[("full_4d", "table")], b[("full_4d", "stand_in")]
    m = float(s["mixture_bytes"])
    return (float(t["ns_per_vertex_best"]) / float(s["ns_per_vertex_best"]), float(t["table_bytes"]) / m,
            float(t["resident_bytes"]) / m, t, s)


def readme_row():
    speed, cells, resident, t, s = ratios()
    return ("| Full-4D table in the render | The stand-in takes %sx the time per path vertex of the mapped 4.2 GB "
            "table (%s against %s ns; the thesis: 40x less); it is %sx smaller than the table's cells; images "
            "%.2f%% apart (4 x 4 blocks), noise %.2f%% | %s |" % (
                times(1 / speed), s["ns_per_vertex_best"], t["ns_per_vertex_best"], times(cells),
                100 * float(s["stand_in_difference_4x4"]), 100 * float(s["table_noise_4x4"]),
                link("render.md", "A full-4D table", "render_4d.csv")))
