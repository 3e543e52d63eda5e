"""The README's results table, row by row from the committed CSVs under bench/results/
(scripts/doc_tables.py writes it between its markers). Each row is short: what was
measured, the figure, and links to the doc that details it and to its CSV."""
import csv
import fnmatch
import functools
import math
import os
import statistics
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RESULTS = os.path.join(ROOT, "bench", "results")
sys.path.insert(0, os.path.join(ROOT, "scripts"))
import compact_tables  # noqa: E402


def rows(name):
    with open(os.path.join(RESULTS, name), newline="") as f:
        return list(csv.DictReader(f))


@functools.lru_cache(maxsize=None)
def provenance():
    """bench/results/provenance.csv by file (read once)."""
    with open(os.path.join(RESULTS, "provenance.csv"), newline="") as f:
        return {r["file"]: r for r in csv.DictReader(f)}


def made_on(*names):
    """Where the files were made, from bench/results/provenance.csv: ' (made on AMD EPYC, 2 CPUs)'."""
    prov = provenance()
    machines = []
    for n in names:
        r = prov.get("bench/results/" + n)
        m = "%s, %s CPUs" % (r["cpu"].replace("(R)", ""), r["logical_cpus"]) if r else "no provenance row"
        if m not in machines:
            machines.append(m)
    return " (made on %s)" % " and ".join(machines)


def pct(x, digits=2):
    return "%.*f%%" % (digits, 100 * float(x))


def times(x):
    """A ratio as the docs write it: 3 significant digits from 10 up, 2 below."""
    x = float(x)
    if x >= 100:
        return "%d" % round(float("%.3g" % x))
    if x >= 10:
        return "%.3g" % x
    t = "%.2g" % x
    return t if "." in t or "e" in t else t + ".0"


def sci(x):
    """1e-08 as 1e-8."""
    m, e = ("%.0e" % float(x)).split("e")
    return "%se%d" % (m, int(e))


def span(values, unit="x"):
    lo, hi = min(values), max(values)
    return times(lo) + unit if times(lo) == times(hi) else "%s-%s%s" % (times(lo), times(hi), unit)


def em_file(k):
    """The newest em_k<k>_<machine>.csv by its provenance row (the first found without one)."""
    import glob
    files = sorted(os.path.basename(f) for f in glob.glob(os.path.join(RESULTS, "em_k%d_*.csv" % k)))
    when = {f: r["utc"] for f, r in provenance().items()}
    return max(files, key=lambda n: when.get("bench/results/" + n, ""))


@functools.lru_cache(maxsize=None)
def stale_files():
    """bench/results/stale.csv's globs (under bench/results/): files made before a change that moves them."""
    with open(os.path.join(RESULTS, "stale.csv"), newline="") as f:
        return tuple(r["file"] for r in csv.DictReader(f))


def stale(*files):
    """Whether one of the files (paths under bench/results/) is listed as stale."""
    return any(fnmatch.fnmatch(f, g) for f in files for g in stale_files())


def link(doc, section, *csvs, used=None):
    """The details cell: the doc (and section), then each CSV; marked when a file the row's
    figures come from (`used`, default the CSVs) is stale."""
    anchor = "#" + section.lower().replace(" ", "-").replace("'", "").replace(",", "").replace(":", "") if section else ""
    return "[%s](docs/%s%s); %s%s" % (doc.replace(".md", ""), doc, anchor,
                                      ", ".join("[CSV](bench/results/%s)" % c for c in csvs),
                                      " (stale: [made before `fit.map: auto`](bench/results/README.md#made-before-fitmap-auto))"
                                      if stale(*(used or csvs)) else "")


def fit():
    s = {r["table"].replace(".h5", ""): r for r in rows("fit_sweep.csv")}["silk"]
    return ("| Fitting | Silk, %s slices of 90 x 180: %.0f s on %s %s cores; median L1 error %s; the "
            "file is %sx smaller than the table | %s |" % (
                s["slices"], float(s["seconds_best"]), s["cores"], cpu_name(rows("fit_sweep.csv")[0].get("cpu_model", "") or provenance()["bench/results/fit_sweep.csv"]["cpu"]),
                pct(s["l1_median"], 1), s["ratio_files"], link("fitting.md", "", "fit_sweep.csv")))


def rivals():
    all_rows = compact_tables.load()
    wins, loses = [], []
    for m in compact_tables.materials(all_rows):
        by = compact_tables.at(all_rows, m, 8192)
        name, best = compact_tables.best_rival(by)
        if "mixture" not in by or not best:
            continue
        mine, theirs = float(by["mixture"]["median_rgb"]), float(best["median_rgb"])
        (wins if mine < theirs else loses).append((m, mine, theirs, compact_tables.LABEL[name]))
    lose = "; ".join("%s wins on %s (%s against %s)" % ("SH" if l.startswith("SH") else l, m, pct(b, 1), pct(a, 1))
                     for m, a, b, l in loses)
    return ("| Stand-in at equal bytes | Lower median RGB error than a smaller table or spherical harmonics at 8 KiB "
            "on %d of %d materials%s | %s |" % (len(wins), len(wins) + len(loses), "; " + lose if lose else "",
                                               link("fitting.md", "The stand-in against its rivals",
                                                    "compact_rivals.csv")))


def constant():
    import converge_tables
    csvs = [os.path.join(RESULTS, "converge", "%s_convergence.csv" % m) for m in ("polyester", "cotton")]
    r = [x for x in converge_tables.measures(csvs, converge_tables.tails_of(csvs), 1024) if x["scene"] == "constant"]
    return ("| BSDF sampling, one point | `mis_tab` matches uniform sampling's error with %s fewer samples "
            "(polyester, cotton; constant light) | %s |" % (
                span([x["mis_fewer"] for x in r]),
                link("sampling.md", "", "converge/", used=["converge/%s_convergence.csv" % m for m in ("polyester", "cotton")])))


def peers():
    """Per material: the mixture's variance per sample over the RGL file's own sampler's, alone and with its
    earned uniform share (mis_tab), median over the views."""
    by = {}
    for r in rows("sampling_peers.csv"):  # the RGL materials under constant light
        if r.get("lighting", "constant") == "constant":
            by.setdefault(r["material"], {}).setdefault(r["theta_o_deg"], {})[r["sampler"]] = r
    by = {m: v for m, v in by.items() if all("rgl" in x for x in v.values())}
    def median_over_rgl(views, sampler):
        return statistics.median(float(v[sampler]["relvar"]) / float(v["rgl"]["relvar"]) for v in views.values())
    ratio = {mat: median_over_rgl(views, "is_mixture") for mat, views in by.items()}
    with_share = {mat: median_over_rgl(views, "mis_mixture") for mat, views in by.items()}
    short = lambda m: m.split("_")[1] if m.startswith("c") and m.count("_") >= 1 else m.split("_")[0]
    # the grids that resolve the lobe, fitted to 2 % L1 (bench/results/rgl_resolve.csv, a few views)
    fine = {r["material"]: r for r in rows("rgl_resolve.csv") if r["grid"] == "resolved_t2" and r["is_mixture_over_rgl_median"]}
    resolved = ("; resolved grids, 2%% L1 fits: %s" % ", ".join(
        "%s %sx" % (short(m), times(float(fine[m]["is_mixture_over_rgl_median"]))) for m in sorted(fine))) if fine else ""
    return ("| Against an RGL file's own sampler | Variance over the file's sampler's, mixture alone / `mis_tab`: "
            "%s%s | %s |" % (
                ", ".join("%s %sx / %sx" % (short(m), times(ratio[m]), times(with_share[m]))
                          for m in sorted(ratio, key=lambda m: ratio[m])),
                resolved,
                link("sampling.md", "Against the file's own sampler", "sampling_peers.csv", "rgl_resolve.csv")))


def lighting():
    import light_tables
    r = light_tables.measures([os.path.join(RESULTS, "converge_light", "%s_convergence.csv" % m)
                               for m in ("polyester", "cotton", "satin", "paper")], 1024)
    return ("| Sampling with lights, one point | `mis_product` needs %s fewer samples than `mis_light_cdf` "
            "(light + table CDF), sky and sky map | %s |" % (
                span([x["mp_vs_base"] for x in r]), link("sampling.md", "Sampling with the lighting", "converge_light/",
                                                          used=["converge_light/%s_convergence.csv" % m
                                                                for m in ("polyester", "cotton", "satin", "paper")])))


def cloth_rows():
    import render_tables
    r = [render_tables.row_for(os.path.join(RESULTS, "render", "%s_%s" % (f, s)))
         for s in ("sky", "skymap") for f in ("silk", "cotton", "wool", "polyester")]
    best = [x["vs_cdf"] for x in r]
    prod = [x["product_vs_cdf"] for x in r if x["product_vs_cdf"]]
    guided = [min(x["guided_vs_cdf"], x["guided_product_vs_cdf"]) for x in r if x["guided_vs_cdf"]]
    wins = sum(b < 1 for b in best)
    estimators = ("| Rendered cloth, equal time | `mis_light_cdf` is best on %d of %d renders; the best mixture "
                  "estimator has %s its error, `mis_product` %s, guided %s | %s |" % (
                      len(r) - wins, len(r), span(best), span(prod), span(guided),
                      link("render.md", "Measured", "render/", used=["render/"])))
    quiet = all(x["stand_in_4x4"] <= 2 or x["stand_in_4x4"] < x["noise_4x4"] for x in r)
    stand_in = ("| Stand-in in the image | %s of the table image (4 x 4 blocks)%s, from mixtures %s smaller "
                "than the table | %s |" % (
                    span([x["stand_in_4x4"] for x in r], "%"), ", within its own noise" if quiet else "",
                    span([x["memory"] for x in r]), link("render.md", "Measured", "render/", used=["render/"])))
    return [estimators, stand_in]


def cpu_name(model):
    """A CPU model as the rows write it: "Intel(R) Xeon(R) Processor" as "Intel Xeon"."""
    return " ".join(w for w in model.replace("(R)", "").replace("(TM)", "").split() if w != "Processor")


def devices():
    b = {r["impl"].split(" ")[0]: r for r in rows(em_file(50))}["bsdfmix"]
    mixed = {r["setup"]: r for r in rows("mixed_devices.csv")}.get("pocl+oclgrind")
    speed = [r for r in rows("em_speed.csv") if r["what"] == "em_seconds_per_iteration"]
    ks = [int(r["k"]) for r in speed]
    pcts = ["%.0f%%" % float(next(r for r in rows(em_file(k)) if r["impl"].startswith("bsdfmix"))["pct_of_fma_peak"])
            for k in (8, 16, 50)]
    return ("| Devices | EM: %.3g G updates/s on %s %s cores (%s of FMA peak at K 8, 16, 50); the current kernels "
            "take %s the time (%s, K %s); PoCL and oclgrind sharing a sweep: K differs on %s of %s slices | %s |" % (
                float(b["pc_per_s"]) / 1e9, b["threads"], cpu_name(b["cpu_model"]),
                ", ".join(pcts), span([float(r["new_over_old"]) for r in speed]),
                cpu_name(speed[0]["cpu_model"]), "-".join(str(k) for k in sorted({min(ks), max(ks)})),
                mixed["slices_k_differ"], mixed["slices"],
                link("em.md", "Devices", "mixed_devices.csv", em_file(50), "em_speed.csv")))


def fit_speed():
    r = rows("fit_speed.csv")
    dl = [abs(float(x[f"new_l1_{q}"]) - float(x[f"old_l1_{q}"])) for x in r for q in ("median", "p90")]
    return ("| Fit time | Default fits of the %d RGL files (90 x 90 x 180): %s s on 2 cores, %s faster than the "
            "9277d9e build, L1 median and p90 within %.2f points | %s |" % (
                len(r), span([round(float(x["new_seconds"])) for x in r], ""),
                span([float(x["speedup"]) for x in r]), 100 * max(dl),
                link("em.md", "Performance", "fit_speed.csv")))


def large_tables():
    r = [r for r in rows("cells_scale.csv") if r["build"] == "this"]
    ns = [float(x["cpu_ns_per_cell"]) for x in r]
    exp = [round(math.log10(int(x["cells"]))) for x in r]
    return ("| Large tables | Fits of 10^%d to 10^%d cells (K 8, 50 iterations): %.0f-%.0f ns of CPU per cell, "
            "peak memory %s-%s MiB | %s |" % (min(exp), max(exp), min(ns), max(ns),
                                 min(int(x["peak_rss_mib"]) for x in r), max(int(x["peak_rss_mib"]) for x in r),
                                 link("studies/cells_scale.md", "", "cells_scale.csv")))


def markdown():
    """The table, as lines."""
    import render_4d_tables  # it reads this module's helpers
    return (["| what | measured | details |", "|---|---|---|", fit(), fit_speed(), large_tables(), rivals(),
             constant(), peers(), lighting()] + cloth_rows() + [render_4d_tables.readme_row(), devices()])
