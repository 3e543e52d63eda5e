#!/usr/bin/python3
"""The tables of docs/fitting.md "The stand-in against its rivals" (the 8 KiB table) and
docs/studies/compact_rivals.md (the others), and the README's size row, from
bench/results/compact_rivals.csv and compact_rivals_image.csv (bench/compact_rivals.py,
bench/compact_image.py); scripts/doc_tables.py writes them between their markers."""
import csv
import os

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RESULTS = os.path.join(ROOT, "bench", "results")
RIVALS = ["table", "table_eval", "sh", "sh_eval"]
LABEL = {"mixture": "mixture", "table": "smaller table + CDF", "table_eval": "smaller table, no CDF",
         "sh": "SH + CDF", "sh_eval": "SH, no CDF"}
GLOSSY = ["silk", "polyester", "satin_rosaline", "cc_iris_purple_gem"]


def load(name="compact_rivals.csv"):
    with open(os.path.join(RESULTS, name), newline="") as f:
        return list(csv.DictReader(f))


def pct(x, digits=2):
    return "%.*f%%" % (digits, 100 * float(x))


def materials(rows):
    out = []
    for r in rows:
        if r["material"] not in out:
            out.append(r["material"])
    return out


def at(rows, mat, budget):
    return {r["representation"]: r for r in rows if r["material"] == mat and int(r["budget"]) == budget}


def best_rival(by):
    """The rival with the lowest median RGB error among those present: (name, row)."""
    got = [(float(by[k]["median_rgb"]), k) for k in RIVALS if k in by]
    return (min(got)[1], by[min(got)[1]]) if got else (None, None)


def at_8k():
    """Per material at 8 KiB: each representation's median RGB error and bytes, the mixture against the
    best rival."""
    rows = load()
    out = ["| material | " + " | ".join(LABEL[k] for k in ["mixture"] + RIVALS) + " | mixture / best rival | the mixture: "
           "slices fitted, K max; its error on them / between them |", "|---|" + "---|" * (len(RIVALS) + 3)]
    for m in materials(rows):
        by = at(rows, m, 8192)
        cells = []
        for k in ["mixture"] + RIVALS:
            r = by.get(k)
            cells.append("%s (%s B)" % (pct(r["median_rgb"]), r["bytes"]) if r else "none under 8 KiB")
        name, best = best_rival(by)
        ratio = "%.2fx (%s)" % (float(by["mixture"]["median_rgb"]) / float(best["median_rgb"]), LABEL[name]) \
            if best and "mixture" in by else ""
        mx = by.get("mixture")
        fit = "%s; %s / %s" % (mx["config"].replace("every ", "1 in "), pct(mx["median_rgb_fitted"]),
                               pct(mx["median_rgb_between"]) if mx["median_rgb_between"] != "nan" else "none") if mx else ""
        out.append("| %s%s | %s | %s | %s |" % (m, " (glossy)" if m in GLOSSY else "", " | ".join(cells), ratio, fit))
    return out


def budgets():
    """Per material and budget: the mixture's median RGB error over the best rival's (below 1: the mixture
    wins), naming the rival."""
    rows = load()
    bs = sorted({int(r["budget"]) for r in rows})
    out = ["| material | " + " | ".join("%d KiB" % (b // 1024) for b in bs) + " |", "|---|" + "---|" * len(bs)]
    for m in materials(rows):
        cells = []
        for b in bs:
            by = at(rows, m, b)
            name, best = best_rival(by)
            if "mixture" not in by or not best:
                cells.append("no mixture under it" if best else "")
                continue
            cells.append("%.2fx %s" % (float(by["mixture"]["median_rgb"]) / float(best["median_rgb"]), LABEL[name]))
        out.append("| %s | %s |" % (m, " | ".join(cells)))
    return out


def cost():
    """At 8 KiB: evaluation ns and the sampling variance of each representation, per material."""
    rows = [r for r in load() if int(r["budget"]) == 8192]
    mats = materials(rows)
    out = ["| representation | eval ns (numpy), " + ", ".join(mats) + " | relative variance per sample, median over "
           "the slices, alone / with 10% uniform | largest share of the integral never sampled |", "|---|---|---|---|"]
    for k in ["mixture"] + RIVALS:
        by = {r["material"]: r for r in rows if r["representation"] == k}
        if not by:
            continue
        ns = ", ".join("%.0f" % float(by[m]["eval_ns"]) if m in by else "-" for m in mats)
        sampled = [m for m in mats if m in by and by[m]["relvar_median"]]
        rv = ", ".join("%.3g / %.3g" % (float(by[m]["relvar_median"]), float(by[m]["relvar_uniform10_median"]))
                       for m in sampled)
        missed = max((float(by[m]["missed_max"]) for m in sampled), default=None)
        out.append("| %s | %s | %s | %s |" % (LABEL[k], ns, rv or "cannot sample", "" if missed is None else "%.2g" % missed))
    if any(not r.get("eval_method") for r in rows if r["representation"] == "mixture"):
        out.append("")
        out.append("The mixture's eval ns in bench/results/compact_rivals.csv come from a numpy evaluation of the "
                   "mixture; the study now times the header's `eval_rgb` through the Python module (stale until "
                   "`bench/reproduce.sh compact_rivals` runs again).")
    return out


def image():
    rows = load("compact_rivals_image.csv")
    out = ["| material | representation | bytes | difference from the table image, 4 x 4 blocks | image mean, "
           "luminance / R / G / B | ns per vertex |", "|---|---|---|---|---|---|"]
    label = {"table_full": "the full table", "table_seed2": "the full table, another seed (noise floor)",
             "stand_in": "the render's own stand-in (K max 16, slices the scene needs)",
             "mixture": "mixture at 8 KiB", "table": "smaller table + CDF at 8 KiB", "sh": "SH + CDF at 8 KiB"}
    for r in rows:
        if r["representation"] == "table_full":
            out.append("| %s | the full table (the image the others are measured against) | | | |  %.0f |" % (
                r["material"], float(r["ns_per_vertex"])))
            continue
        out.append("| %s | %s | %s | %s | %s |  %.0f |" % (
            r["material"], label.get(r["representation"], r["representation"]), r["bytes"] or "",
            pct(r["difference_4x4"]), " / ".join("%+.2f%%" % (100 * float(r[c]))
                                                 for c in ("mean_luminance", "mean_r", "mean_g", "mean_b")),
            float(r["ns_per_vertex"])))
    return out


def readme_row():
    rows = load()
    parts = []
    for m in materials(rows):
        by = at(rows, m, 8192)
        name, best = best_rival(by)
        if "mixture" in by and best:
            parts.append("%s %s against %s (%s)" % (m, pct(by["mixture"]["median_rgb"], 1), pct(best["median_rgb"], 1),
                                                     LABEL[name]))
    img = load("compact_rivals_image.csv")
    di = []
    for m in materials(img):
        by = {r["representation"]: r for r in img if r["material"] == m}
        if "mixture" in by and "table" in by:
            di.append("%s %s against the smaller table's %s and SH's %s" % (
                m, pct(by["mixture"]["difference_4x4"], 1), pct(by["table"]["difference_4x4"], 1),
                pct(by["sh"]["difference_4x4"], 1) if "sh" in by else "-"))
    return ("| the stand-in against a smaller table and spherical harmonics at 8 KiB, every table slice (90 theta_o of "
            "90 x 180), median RGB error, the mixture against the best rival | " + "; ".join(parts) +
            "; in the image (4 x 4 blocks, 128 x 128): " + "; ".join(di) + " | `bench/reproduce.sh compact_rivals` "
            "([CSV](bench/results/compact_rivals.csv), [image CSV](bench/results/compact_rivals_image.csv), "
            "[chart](docs/images/compact_rivals.png), docs/fitting.md \"The stand-in against its rivals\") |")
