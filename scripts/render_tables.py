#!/usr/bin/python3
"""The measured table of `bsdfmix render` (docs/studies/render_cloth.md, "The measured renders"), from
render.csv and render.json.

For every render directory given, one row:
  equal-time rel MSE   of uniform, of the best mixture estimator (mis_tab, mis_light_gmm,
                       mis_product)
                       and of the best table-CDF estimator (cdf_tab, mis_light_cdf)
  vs uniform           uniform's rel MSE over the best mixture estimator's 
                      
  vs table CDF         the best mixture estimator's rel MSE over the best table CDF
                       estimator's
  product vs light CDF mis_product's rel MSE over mis_light_cdf's (the renderers' baseline)
  guided vs light CDF  guided's and guided_product's rel MSE over mis_light_cdf's, and the best
                       of mis_product, guided and guided_product over it; empty on a
                       render without the guided estimators
  ns per vertex        the cost of a path vertex of mis_light_cdf and of mis_product
  memory               table bytes / mixture bytes and full 4D table bytes /
                       mixture bytes
  stand-in             sum |stand-in - table| / sum table per pixel and over 4 x 4 blocks
                       and the images' means
  64 spp               the slowest estimator's seconds for `spp` samples per pixel at the
                       render's size
  rays/s               the range over the estimators' equal-sample renders

  scripts/render_tables.py out/render_silk/sky out/render_cotton/sky ... [--markdown]
"""

import argparse
import csv
import json
import os

from tables_common import failer, fmt, print_table

fail = failer("render_tables")
MIXTURE = ["mis_tab", "mis_light_gmm", "mis_product"]
TABLE_CDF = ["cdf_tab", "mis_light_cdf"]
NEW = ["mis_product", "guided", "guided_product"]  # the estimators beyond the renderers' baseline


def read_render(d, fail=fail):
    """A render directory's render.csv rows and render.json."""
    try:
        with open(os.path.join(d, "render.csv"), newline="") as f:
            rows = list(csv.DictReader(f))
        with open(os.path.join(d, "render.json")) as f:
            meta = json.load(f)
    except (OSError, ValueError) as e:
        fail("%s: %s" % (d, e))
    return rows, meta


def row_for(d):
    rows, meta = read_render(d)
    eq_time = {r["estimator"]: float(r["rel_mse"]) for r in rows if r["mode"] == "equal_time"}
    eq_spp = [r for r in rows if r["mode"] == "equal_spp"]
    if "uniform" not in eq_time:
        fail("%s: no equal_time row for uniform" % d)
    best = lambda names: min(((eq_time[n], n) for n in names if n in eq_time), default=(None, None))
    mix, mix_name = best(MIXTURE)
    cdf, cdf_name = best(TABLE_CDF)
    mb = float(meta["mixture_bytes"])
    ns = {r["estimator"]: float(r["ns_per_vertex"]) for r in eq_spp if r.get("ns_per_vertex")}
    ratio = lambda a, b: eq_time[a] / eq_time[b] if a in eq_time and b in eq_time and eq_time[b] > 0 else None
    return dict(
        fiber=meta["fiber"].replace("_table", ""), scene=meta["scene"],
        size="%dx%d" % (meta["width"], meta["height"]),
        uniform=eq_time["uniform"], mixture=mix, mixture_name=mix_name, cdf=cdf, cdf_name=cdf_name,
        vs_uniform=eq_time["uniform"] / mix if mix else None,
        vs_cdf=mix / cdf if mix and cdf else None,
        product_vs_cdf=ratio("mis_product", "mis_light_cdf"),
        guided_vs_cdf=ratio("guided", "mis_light_cdf"), guided_product_vs_cdf=ratio("guided_product", "mis_light_cdf"),
        best_new_vs_cdf=min((ratio(n, "mis_light_cdf") for n in NEW if ratio(n, "mis_light_cdf")), default=None)
        if "guided" in eq_time else None,
        worst_new_vs_cdf=max((ratio(n, "mis_light_cdf") for n in NEW if ratio(n, "mis_light_cdf")), default=None)
        if "guided" in eq_time else None,
        ns_cdf=ns.get("mis_light_cdf"), ns_product=ns.get("mis_product"),
        memory=float(meta["table_bytes"]) / mb, memory_full=float(meta["full_table_bytes"]) / mb,
        stand_in=100 * float(meta.get("stand_in_difference", -1)),
        stand_in_4x4=100 * float(meta.get("stand_in_difference_4x4", -1)),
        stand_in_mean=100 * float(meta.get("stand_in_mean_difference", 0)),
        noise_4x4=100 * float(meta.get("table_noise_4x4", 0)),
        slices="%s/%s" % (meta["slices_needed"], meta["slices_total"]),
        slowest=max(float(r["seconds"]) for r in eq_spp),
        spp=int(eq_spp[0]["spp"]) if eq_spp else 0,
        rays="%.1f-%.1f M" % (min(float(r["rays_per_second"]) for r in eq_spp) / 1e6,
                              max(float(r["rays_per_second"]) for r in eq_spp) / 1e6),
    )


COLS = [("fiber", "fiber", None), ("scene", "scene", None), ("size", "size", None),
        ("uniform rel MSE", "uniform", None), ("best mixture", "mixture_name", None),
        ("its rel MSE", "mixture", None), ("best table CDF", "cdf_name", None), ("its rel MSE", "cdf", None),
        ("vs uniform", "vs_uniform", lambda x, r: x >= 5 or r["scene"] != "sky"),
        ("vs table CDF", "vs_cdf", lambda x, r: x <= 1.5),
        ("mis_product / mis_light_cdf", "product_vs_cdf", lambda x, r: x <= 0.5),
        ("guided / mis_light_cdf", "guided_vs_cdf", lambda x, r: x <= 1.1),
        ("guided_product / mis_light_cdf", "guided_product_vs_cdf", lambda x, r: x <= 1.1),
        ("best new / mis_light_cdf", "best_new_vs_cdf", lambda x, r: x <= 0.5),
        ("ns/vertex mis_light_cdf", "ns_cdf", None), ("ns/vertex mis_product", "ns_product", None),
        ("table / mixtures", "memory", lambda x, r: x >= 100),
        ("full 4D / mixtures", "memory_full", lambda x, r: x >= 1000),
        ("slices fitted", "slices", None),
        ("stand-in diff % (pixels)", "stand_in", None),
        ("stand-in diff % (4x4)", "stand_in_4x4", lambda x, r: x <= 2),
        ("stand-in mean %", "stand_in_mean", None),
        ("slowest 64 spp (s)", "slowest", lambda x, r: x <= 120 or r["size"] != "256x256"),
        ("rays/s (2 cores)", "rays", None)]


def cell(r, name, ok):
    x = r[name]
    return fmt(x)


def markdown(dirs):
    """The Markdown table of the render directories, as lines (scripts/doc_tables.py)."""
    rows = [row_for(d) for d in dirs]
    out = ["| " + " | ".join(c[0] for c in COLS) + " |", "|" + "---|" * len(COLS)]
    for r in rows:
        out.append("| " + " | ".join(cell(r, n, ok) for _, n, ok in COLS) + " |")
    return out


def reading(dirs):
    """The reading of the renders (docs/render.md, "Measured"), as lines: every figure
    from the rows, so that it cannot drift from them."""
    rows = [row_for(d) for d in dirs]
    f2 = lambda x: "%d" % round(float("%.3g" % x)) if x >= 100 else "%.3g" % x
    span = lambda xs, unit="x": (f2(min(xs)) + unit if f2(min(xs)) == f2(max(xs))
                                 else "%s%s to %s%s" % (f2(min(xs)), unit, f2(max(xs)), unit))
    where = lambda r: "%s under the %s" % (r["fiber"], "sky" if r["scene"] == "sky" else "sky map")
    sky = [r for r in rows if r["scene"] == "sky"]
    other = [r for r in rows if r["scene"] != "sky"]
    best = sorted({r["mixture_name"] for r in rows})
    ok = [r for r in rows if r["vs_cdf"] <= 1.5]
    bad = [r for r in rows if r["vs_cdf"] > 1.5]
    prod = [r["product_vs_cdf"] for r in rows if r["product_vs_cdf"]]
    vertex = [r["ns_product"] / r["ns_cdf"] for r in rows if r["ns_product"] and r["ns_cdf"]]
    blocks_ok = [r for r in rows if r["stand_in_4x4"] <= 2]
    blocks_noisy = [r for r in rows if r["stand_in_4x4"] > 2]
    fitted = sorted({r["slices"] for r in rows})
    out = [
        "- **Equal time against uniform:** the best mixture estimator (%s) has %s less relative MSE than uniform "
        "sampling under the sky, %s under the sky map." % (
            ", ".join("`%s`" % b for b in best), span([r["vs_uniform"] for r in sky]),
            span([r["vs_uniform"] for r in other])),
        "- **Against the table CDF:** its error is %s `mis_light_cdf`'s on %d of the %d rows%s." % (
            span([r["vs_cdf"] for r in ok]), len(ok), len(rows),
            "" if not bad else "; above it: " + ", ".join("%s (%.2fx)" % (where(r), r["vs_cdf"]) for r in bad)),
        "- **Product sampling with the lighting** (`mis_product`): %s `mis_light_cdf`'s relative MSE at equal time"
        "%s. A `mis_product` vertex is %s dearer (%s against %s ns)." % (
            span(prod), " (`mis_light_cdf` is better on every row)" if min(prod) > 1 else "", span(vertex),
            span([r["ns_product"] for r in rows if r["ns_product"]], ""), span([r["ns_cdf"] for r in rows if r["ns_cdf"]], "")),
    ]
    guided = [r for r in rows if r["guided_vs_cdf"] is not None]
    if guided:
        out.append(
            "- **Guided paths** (`guided`, `guided_product`, trained in the render's own budget): %s and %s "
            "`mis_light_cdf`'s relative MSE at equal time; the best of the new estimators (`mis_product` and "
            "the two guided ones) %s, below 1x on %d of %d rows; the worst %s%s." % (
                span([r["guided_vs_cdf"] for r in guided]), span([r["guided_product_vs_cdf"] for r in guided]),
                span([r["best_new_vs_cdf"] for r in guided]),
                sum(r["best_new_vs_cdf"] < 1 for r in guided), len(guided),
                span([r["worst_new_vs_cdf"] for r in guided]),
                "" if len(guided) == len(rows) else "; the other rows (%s) were rendered without the guided "
                "estimators and have none" % ", ".join(where(r) for r in rows if r["guided_vs_cdf"] is None)))
    out += [
        "- **The stand-in against the table** (the same estimator and seed, 4 x 4 blocks): %s on %d of the %d rows%s; "
        "image means within %.2f%% but %s." % (
            span([r["stand_in_4x4"] for r in blocks_ok], "%"), len(blocks_ok), len(rows),
            "" if not blocks_noisy else "; " + ", ".join("%.2f%% on %s (the table image's own noise there: %.1f%%)" % (
                r["stand_in_4x4"], where(r), r["noise_4x4"]) for r in blocks_noisy),
            max(abs(r["stand_in_mean"]) for r in rows if abs(r["stand_in_mean"]) <= 0.5) if any(
                abs(r["stand_in_mean"]) <= 0.5 for r in rows) else 0,
            ", ".join("%s (%+.2f%%)" % (where(r), r["stand_in_mean"]) for r in rows if abs(r["stand_in_mean"]) > 0.5)
            or "on no row"),
        "- **Speed:** the slowest estimator takes %s for its samples per pixel at 256 x 256; "
        "%s to %s M rays per second on 2 cores. Slices fitted (the pre-pass): %s." % (
            span([r["slowest"] for r in rows], " s"), "%.1f" % min(float(r["rays"].split("-")[0]) for r in rows),
            "%.1f" % max(float(r["rays"].split("-")[1].split()[0]) for r in rows), ", ".join(fitted)),
    ]
    return out


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
