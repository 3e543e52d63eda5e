#!/usr/bin/python3
"""The guided estimators against the renderers' baseline (docs/studies/render_guided.md, "In the
room"), from the render.csv of each render directory given (the room renders).

For every directory, one row: the equal-time relative MSE of mis_light_cdf (the baseline),
mis_light_gmm, mis_product, guided and guided_product; the best of the three new ones
(mis_product, guided, guided_product) over the baseline ; guided_product over guided; and the cost of a
path vertex of each (thread-nanoseconds at equal samples, the guided ones' training passes
and fits included).

  scripts/room_tables.py bench/results/render/silk_room ... [--markdown]
"""

import argparse

from render_tables import cell, read_render
from tables_common import failer, markdown_lines, print_table

fail = failer("room_tables")
ESTIMATORS = ["mis_light_cdf", "mis_light_gmm", "mis_product", "guided", "guided_product"]
NEW = ["mis_product", "guided", "guided_product"]


def row_for(d):
    rows, meta = read_render(d, fail)
    eq_time = {r["estimator"]: float(r["rel_mse"]) for r in rows if r["mode"] == "equal_time"}
    missing = [e for e in ESTIMATORS if e not in eq_time]
    if missing:
        fail("%s: no equal_time row for %s" % (d, ", ".join(missing)))
    ns = {r["estimator"]: float(r["ns_per_vertex"]) for r in rows if r["mode"] == "equal_spp" and r["ns_per_vertex"]}
    eq_spp = {r["estimator"]: float(r["rel_mse"]) for r in rows if r["mode"] == "equal_spp"}
    base = eq_time["mis_light_cdf"]
    best = min(NEW, key=lambda e: eq_time[e])
    out = dict(fiber=meta["fiber"].replace("_table", ""), best_name=best, best=eq_time[best] / base,
               worst=max(eq_time[e] / base for e in NEW), product_vs_guided=eq_time["guided_product"] / eq_time["guided"],
               seconds=float(meta.get("equal_time_seconds", 0)))
    for e in ESTIMATORS:
        out[e] = eq_time[e]
        out["ns_" + e] = ns.get(e)
        out["spp_" + e] = eq_spp.get(e)
    return out


COLS = ([("fiber", "fiber", None)] + [("%s rel MSE" % e, e, None) for e in ESTIMATORS] +
        [("best new", "best_name", None), ("best new / mis_light_cdf", "best", lambda x, r: x <= 0.25),
         ("worst new / mis_light_cdf", "worst", lambda x, r: x <= 1.1),
         ("guided_product / guided", "product_vs_guided", lambda x, r: x < 1)] +
        [("ns/vertex %s" % e, "ns_" + e, None) for e in ESTIMATORS])


def markdown(dirs):
    return markdown_lines([row_for(d) for d in dirs], COLS, cell)


def reading(dirs):
    """The reading under the table, every figure from its rows."""
    rows = [row_for(d) for d in dirs]
    span = lambda xs: ("%.3gx" % min(xs)) if "%.3g" % min(xs) == "%.3g" % max(xs) else "%.3gx to %.3gx" % (min(xs), max(xs))
    gmm = [r["mis_light_gmm"] / r["mis_light_cdf"] for r in rows]
    guided = [r["guided"] / r["mis_light_cdf"] for r in rows]
    gprod = [r["guided_product"] / r["mis_light_cdf"] for r in rows]
    vs_gmm = [min(r["guided"], r["guided_product"]) / r["mis_light_gmm"] for r in rows]
    cost = [r["ns_guided"] / r["ns_mis_light_gmm"] for r in rows if r["ns_guided"] and r["ns_mis_light_gmm"]]
    per_sample = [r["spp_" + e] / r["spp_mis_light_gmm"] for r in rows for e in ("guided", "guided_product")]
    return [
        "- **In the room, against the baseline** (`mis_light_cdf`, equal time): `mis_light_gmm` %s, `guided` %s, "
        "`guided_product` %s; below 1x (better than the baseline): %s." % (
            span(gmm), span(guided), span(gprod),
            ", ".join("`%s` on %d of %d fibers" % (e, sum(r[e] < r["mis_light_cdf"] for r in rows), len(rows))
                      for e in ("mis_light_gmm", "guided", "guided_product"))),
        "- **Guiding against the mixture it guides** (`mis_light_gmm`, which samples as the guided estimators do where "
        "a leaf does not guide): at equal time the better guided estimator's error is %s its error; at equal samples "
        "both guided estimators' errors are %s its error, and a guided vertex costs %s a `mis_light_gmm` vertex, "
        "training passes and fits included." % (span(vs_gmm), span(per_sample), span(cost)),
    ]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("dirs", nargs="+", help="render output directories (render.csv, render.json)")
    ap.add_argument("--markdown", action="store_true")
    a = ap.parse_args()
    if a.markdown:
        print("\n".join(markdown(a.dirs)))
        return
    print_table([row_for(d) for d in a.dirs], COLS, cell, False)


if __name__ == "__main__":
    main()
