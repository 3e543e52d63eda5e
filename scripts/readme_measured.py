"""The README's "Measured" table, row by row from the committed CSVs under bench/results/
(scripts/doc_tables.py writes it between its markers; each row names the command that
makes its CSV)."""
import csv
import functools
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


def em():
    name = em_file(50)
    by = {r["impl"].split(" ")[0]: r for r in rows(name)}
    b = by["bsdfmix"]
    peer = lambda n: "%.3g M" % (float(by[n]["pc_per_s"]) / 1e6) if n in by else "not run"
    return ("| EM throughput, K = 50, 90 x 180 slices (best of 10) | %.3g G point-component updates/s "
            "on %s threads: %s%% of this machine's measured FMA peak (%s GFLOP/s), at %s flops per update counted from "
            "the kernel; on one thread each: Armadillo %s (`-O3`; %s with `-march=native`), pomegranate %s, "
            "scikit-learn %s, the CPU reference %s | `bench/reproduce.sh em` ([CSV](bench/results/%s), "
            "[chart](docs/images/em_throughput.png), bench/README.md) |" % (
                float(b["pc_per_s"]) / 1e9, b["threads"], b["pct_of_fma_peak"], b["fma_peak_gflops"],
                b["flops_per_update"], peer("armadillo_generic"), peer("armadillo"), peer("pomegranate"),
                peer("scikit-learn"), peer("cpu_reference"), name))


def fit_sweep():
    by = {r["table"].replace(".h5", ""): r for r in rows("fit_sweep.csv")}
    s, p = by["silk"], by["polyester"]
    first = ("| thesis-scale silk, %s slices of 90 x 180, in colour, K in [%s, %s] (best of %s) | %.0f s; relative L1 "
             "median %s, p90 %s; the mixture file is %sx smaller than the table file (which holds `rgb` beside "
             "`values`; %sx the luminance cells against the mixture's datasets, `rgb_scale` and padding included); "
             "azimuthal symmetry already stores 1 phi_o of 180: against the full 4D float32 luminance table, %sx | "
             "`RUNS=3 bench/fit_sweep.sh` ([CSV](bench/results/fit_sweep.csv)) |" % (
                 s["slices"], s["k_min"], s["k_max"], s["runs"], float(s["seconds_best"]), pct(s["l1_median"], 1),
                 pct(s["l1_p90"], 1), s["ratio_files"], s["ratio_datasets"], times(s["ratio_full"])))
    second = ("| thesis-scale polyester, same | %.0f s; relative L1 median %s, p90 %s; %sx (file), %sx (payload), %sx "
              "(full 4D) | same |" % (float(p["seconds_best"]), pct(p["l1_median"], 1), pct(p["l1_p90"], 1),
                                      p["ratio_files"], p["ratio_datasets"], times(p["ratio_full"])))
    return [first, second]


def search():
    sc = {(r["table"], r["search"], r["refine"], r["run"]): r for r in rows("search_compare.csv")}
    best3 = {(r["search"], r["refine"], r["run"]): r for r in rows("search_compare_polyester_best3.csv")}
    rgl = ("satin", "paper", "sunflower")
    old = [sc[(t, "restarts", "none", "search")] for t in rgl]
    new = [sc[(t, "smem", "l1", "search")] for t in rgl]
    t_new, t_old = float(best3[("smem", "l1", "search")]["seconds"]), float(best3[("restarts", "none", "search")]["seconds"])
    return ("| the Gaussian-count search on the RGL materials satin, paper, sunflower (90 slices of 90 x 180 each) | the "
            "median relative L1 error falls from %s to %s with %s components (mean K %s against %s), by a walk over K "
            "with split-and-merge moves and an L1 refinement of the final fits; the thesis-scale polyester search in "
            "%.2fx the time of the restarts it replaces (%.1f s against %.1f s, best of 3) | `bench/search_compare.py "
            "--runs 1 --chart` ([CSV](bench/results/search_compare.csv), docs/fitting.md); times: "
            "`bench/search_compare.py --tables polyester --csv bench/results/search_compare_polyester_best3.csv` "
            "([CSV](bench/results/search_compare_polyester_best3.csv)) |" % (
                ", ".join(pct(r["l1_median"]) for r in old), ", ".join(pct(r["l1_median"]) for r in new),
                "fewer" if all(float(n["mean_k"]) < float(o["mean_k"]) for n, o in zip(new, old)) else "about as many",
                ", ".join("%.1f" % float(r["mean_k"]) for r in new), ", ".join("%.1f" % float(r["mean_k"]) for r in old),
                t_new / t_old, t_new, t_old))


def before_after():
    by = {(r["table"], r["build"]): r for r in rows("search_before_after.csv")}
    chi = {r["label"]: r for r in rows("search_before_after_chi_square.csv")}
    name = {"iris": "cc_iris_purple_gem"}
    tables = [t for t in ("hard", "satin", "paper", "sunflower", "iris", "silk", "cotton", "polyester", "wool")
              if (t, "before") in by and (t, "after") in by]
    f = lambda t, b, c: float(by[(t, b)][c])
    pair = lambda t, c: "%s to %s" % (pct(f(t, "before", c), 1), pct(f(t, "after", c), 1))
    up = [(t, c) for t in tables for c in ("l1_median", "l1_p90") if f(t, "after", c) > f(t, "before", c)]
    up_by = max((f(t, "after", c) - f(t, "before", c) for t, c in up), default=0)
    worst = max(tables, key=lambda t: float(chi[t]["ratio_max"]) if t in chi else 0)
    chi_ok = all(float(chi[t]["chi_mean_after"]) <= float(chi[t]["chi_mean_before"]) * 1.005 for t in chi)
    time_r = [f(t, "after", "seconds") / f(t, "before", "seconds") for t in tables if t != "hard"]
    dk = {t: f(t, "after", "mean_k") - f(t, "before", "mean_k") for t in tables if t != "hard"}
    most = max(dk, key=dk.get)
    # The walk alone (the after build with the colour work off), and the thesis-scale sweep's time.
    walk = [t for t in tables if t != "hard" and (t, "after_walk") in by]
    thesis = {r["build"]: r for r in rows("search_time.csv")}
    walk_text = ""
    if walk and {"before", "after", "after_walk"} <= set(thesis):
        sec = lambda b: float(thesis[b]["seconds"])
        dk_walk = [f(t, "after_walk", "mean_k") - f(t, "before", "mean_k") for t in walk]
        walk_text = ("; the walk alone (the colour work off): %s the fit time in the same run (one run per row, "
                     "noisy) and %.2f to %.2f more components on the mean; the thesis-scale polyester "
                     "sweep, best of 3: %.2fx (the walk alone) and "
                     "%.2fx (with the colour work) the time before, mean K %.2f and %.2f against %.2f" % (
                         span([f(t, "after_walk", "seconds") / f(t, "before", "seconds") for t in walk]),
                         min(dk_walk), max(dk_walk),
                         sec("after_walk") / sec("before"), sec("after") / sec("before"),
                         float(thesis["after_walk"]["mean_k"]), float(thesis["after"]["mean_k"]),
                         float(thesis["before"]["mean_k"])))
    return ("| the walk over K on a sharp peak 30x its base with fringes (`bench/hard_table.py`), the RGL materials and "
            "the fiber presets, before and after it restarts stalled Ks twice (the last fit grown, the best fit seeded "
            "at the residual), weighs the K above, and fits a stalled walk with a poor best fit past its last K | hard "
            "table: p90 L1 %s, max %s; satin: p90 %s, max %s; paper max %s, sunflower %s; the sharp colour-shifting "
            "film cc_iris_purple_gem: median %s, p90 %s, max %s (after: the code as it stands, the channels moving "
            "the Gaussians on the coloured tables included); %s, %s, %d medians or p90s up by at most %.2f points; "
            "importance sampling (mean chi-square "
            "divergence) %s, %s's worst slice %.2fx; %s the fit time and up to %.2f more components on the mean on the "
            "measured and fiber tables (%s)%s | "
            "`BEFORE=OLD/build/bsdfmix bench/reproduce.sh search_before_after search_time` "
            "([CSV](bench/results/search_before_after.csv), [chi-square](bench/results/search_before_after_chi_square.csv), "
            "[time](bench/results/search_time.csv), docs/fitting.md \"A walk that does not give up\") |" % (
                pair("hard", "l1_p90"), pair("hard", "l1_max"), pair("satin", "l1_p90"), pair("satin", "l1_max"),
                pair("paper", "l1_max"), pair("sunflower", "l1_max"), pair("iris", "l1_median"), pair("iris", "l1_p90"),
                pair("iris", "l1_max"),
                "no slice above 10%" if all(f(t, "after", "l1_max") <= 0.10 for t in tables) else
                "a slice above 10%% on %s only" % ", ".join(name.get(t, t) for t in tables if f(t, "after", "l1_max") > 0.10),
                "every max lower" if all(f(t, "after", "l1_max") <= f(t, "before", "l1_max") for t in tables)
                else "not every max lower", len(up), 100 * up_by,
                "the same or better on every table" if chi_ok else "worse on some tables", worst,
                float(chi[worst]["ratio_max"]), span(time_r), max(dk.values()), name.get(most, most), walk_text))


def stand_in():
    by = {r["table"]: r for r in rows("rgb_stand_in.csv")}
    alone = {r["table"]: r for r in rows("rgb_refine.csv") if r["variant"] == "alone"}
    plain = {r["table"]: r for r in rows("rgb_stand_in_no_copies.csv")}
    rgl = tuple(t for t in ("satin", "paper", "sunflower", "iris") if t in by)
    fibers = ("silk", "cotton", "polyester", "wool")
    label = {"iris": "cc_iris_purple_gem"}
    energy = max(float(by[t]["energy_max_" + c]) for t in by for c in "yrgb")
    diff = max(max(float(by[t]["l1_diff_points"]), float(by[t]["rgb_diff_points"])) for t in by)
    neg = [t for t in rgl if by[t]["rgb_median"] != by[t]["rgb_less_negative_median"]]
    met = sum(float(r["ratio"]) <= 1.2 for r in by.values())
    grey = [t for t in fibers if t != "polyester"]
    return ("| the chromatic stand-in on the RGL materials %s and the fiber presets silk, cotton, "
            "polyester (dyed red), wool (per-component R, G, B amplitudes on the luminance's Gaussians, and four colour "
            "copies of each Gaussian on the slices whose colour changes across a lobe) | the stand-in's "
            "integral over the domain equals the table's in the luminance and every channel (to %s); RGB error median "
            "%s on the RGL materials%s, %s the luminance L1 median (with the luminance alone in the L1 refinement %s: "
            "`fit.refine_rgb`, [CSV](bench/results/rgb_refine.csv)); %s on %s, %sx on the red polyester (target 1.2x, "
            "met by %d of %d; without colour copies %s on the RGL materials, [CSV](bench/results/rgb_stand_in_no_copies.csv)); "
            "the report's errors equal a recomputation from the files through the header (to %s "
            "points) | `/usr/bin/python3 bench/rgb_stand_in.py`, `bench/rgb_refine.py` "
            "([CSV](bench/results/rgb_stand_in.csv), docs/fitting.md \"Colour and energy\", \"Colour copies\") |" % (
                ", ".join(label.get(t, t) for t in rgl), sci(energy), ", ".join(pct(by[t]["rgb_median"]) for t in rgl),
                "".join(" (%s outside the cells where %s's measured channels are below zero)" % (
                    pct(by[t]["rgb_less_negative_median"]), label.get(t, t)) for t in neg),
                ", ".join("%.2fx" % float(by[t]["ratio"]) for t in rgl),
                ", ".join("%s %.2fx" % (label.get(t, t), float(alone[t]["ratio"])) for t in rgl if t in alone),
                span([float(by[t]["ratio"]) for t in grey]), ", ".join(grey), "%.2f" % float(by["polyester"]["ratio"]),
                met, len(by), ", ".join("%s %.2fx" % (label.get(t, t), float(plain[t]["ratio"])) for t in rgl if t in plain),
                sci(diff)))


def smallest():
    every = {"1": "every theta_o row", "2": "every 2nd row", "4": "every 4th row"}
    all_rows = rows("stand_in_bytes.csv")
    parts = []
    for m in ("paper_white", "satin_rosaline", "cg_sunflower"):
        ok = sorted((r for r in all_rows if r["material"] == m and float(r["median_rgb_error"]) <= 0.05),
                    key=lambda r: int(r["bytes"]))
        parts.append("%s %s" % (m, "none in this grid" if not ok else "%s bytes (%s, K max %s, %s)" % (
            ok[0]["bytes"], every.get(ok[0]["every"], "every %s" % ok[0]["every"]), ok[0]["k_max"],
            "`%s` storage" % ok[0]["storage"])))
    return ("| the smallest stand-in at a median RGB error of 5% or less, compared at every table slice (30 theta_o of 90 "
            "x 180) | " + ", ".join(parts) + "; the shipped `.bsdf` files are 644 to 1030 KiB | `/usr/bin/python3 "
            "bench/stand_in_bytes.py` ([CSV](bench/results/stand_in_bytes.csv), [chart](docs/images/stand_in_bytes.png), "
            "docs/fitting.md \"How small a stand-in can be\") |")


def lighting():
    import light_targets
    r = light_targets.targets([os.path.join(RESULTS, "converge_light", "%s_convergence.csv" % m)
                               for m in ("polyester", "cotton", "satin", "paper")], 1024)
    sky = [x for x in r if x["scene"] == "sky"]
    sm = [x for x in r if x["scene"] == "skymap"]
    return ("| sampling with the lighting: polyester, cotton, RGL satin and paper at 3 directions each, under the sky "
            "(4-degree sun) and a Preetham sky map (1-degree sun) | `mis_product` (the BSDF mixture times a lighting "
            "mixture fitted by the same EM, with light and uniform samples mixed in) reaches `us_tab`'s error at 1024 "
            "samples with %s fewer samples under the sky and %s under the map, %s fewer than light sampling + table "
            "CDF by MIS (the renderer baseline); a sample costs %s a uniform one; largest f/pdf over the integral %s | "
            "`build/bsdfmix run configs/converge_light_<m>.yaml` for the four, `scripts/light_targets.py` "
            "([CSVs](bench/results/converge_light/), docs/sampling.md) |" % (
                span([x["mp_fewer"] for x in sky]), span([x["mp_fewer"] for x in sm]),
                span([x["mp_vs_base"] for x in r]), span([x["cost_mp"] for x in r]),
                span([x["max_weight"] for x in r], "")))


def cloth():
    import render_targets
    r = [render_targets.row_for(os.path.join(RESULTS, "render", "%s_%s" % (f, s)))
         for s in ("sky", "skymap") for f in ("silk", "cotton", "wool", "polyester")]
    gmm = [x for x in r if x["mixture_name"] == "mis_light_gmm"]
    ok = [x for x in r if x["vs_cdf"] <= 1.5]
    bad = [x for x in r if x["vs_cdf"] > 1.5]
    vertex = [x["ns_product"] / x["ns_cdf"] for x in r if x["ns_product"] and x["ns_cdf"]]
    prod = [x["product_vs_cdf"] for x in r if x["product_vs_cdf"]]
    guided = [x for x in r if x["guided_vs_cdf"]]
    guiding = ("; guided paths (`guided`, `guided_product`, trained within the budget): %s and %s `mis_light_cdf`'s "
               "error at equal time on the %d rendered with them (target: none above 1.1x, %s)" % (
                   span([x["guided_vs_cdf"] for x in guided]), span([x["guided_product_vs_cdf"] for x in guided]),
                   len(guided), "missed" if any(x["worst_new_vs_cdf"] > 1.1 for x in guided) else "met")
               if guided else "")
    return ("| rendered cloth, 256 x 256, 64 spp: silk, cotton, wool and polyester under the sky and under the sky map | "
            "at equal time the best mixture estimator (%s) has %s less relative MSE than uniform sampling under the sky, "
            "%s under the map; %s the table CDF estimator's error (`mis_light_cdf`, the renderers' baseline) on %d of "
            "the %d%s, with mixtures %s smaller than the table and %s smaller than the full 4D table; product sampling "
            "with the lighting (`mis_product`): %s `mis_light_cdf`'s error at equal time, a vertex %s dearer (target "
            "0.5x%s)%s; the stand-in image within %s of the table image (4 x 4 blocks)%s; 64 spp in %.0f-%.0f s, %s-%s M "
            "rays/s on 2 cores | `bench/reproduce.sh render` (`build/bsdfmix render configs/render/<fiber>_<scene>.yaml`), "
            "`scripts/render_targets.py` ([CSVs](bench/results/render/), docs/render.md) |" % (
                "`mis_light_gmm`" if len(gmm) == len(r) else "mostly `mis_light_gmm`",
                span([x["vs_uniform"] for x in r if x["scene"] == "sky"]),
                span([x["vs_uniform"] for x in r if x["scene"] == "skymap"]),
                span([x["vs_cdf"] for x in ok]), len(ok), len(r),
                "".join(", %.2fx on %s under the %s" % (x["vs_cdf"], x["fiber"], "sky" if x["scene"] == "sky" else "map")
                        for x in bad),
                span([x["memory"] for x in r]), span([x["memory_full"] for x in r]), span(prod), span(vertex),
                ", missed" if max(prod) > 0.5 else ", met", guiding, span([x["stand_in_4x4"] for x in r], "%"),
                "" if all(x["stand_in_4x4"] <= 2 for x in r) else ", above 2% only under the table image's own noise"
                if all(x["stand_in_4x4"] <= 2 or x["stand_in_4x4"] < x["noise_4x4"] for x in r)
                else ", above 2% and above the table image's own noise on some",
                min(x["slowest"] for x in r), max(x["slowest"] for x in r),
                "%.1f" % min(float(x["rays"].split("-")[0]) for x in r),
                "%.1f" % max(float(x["rays"].split("-")[1].split()[0]) for x in r)))


def room():
    import guide_targets
    r = [guide_targets.row_for(os.path.join(RESULTS, "render", "%s_room" % f)) for f in ("silk", "cotton", "wool", "polyester")]
    ratio = lambda name: [x[name] / x["mis_light_cdf"] for x in r]
    return ("| guided paths, the cloth of the four fibers in a room lit through a skylight, 256 x 256 | at equal time, "
            "training included, against `mis_light_cdf`: `guided` %s, `guided_product` %s, `mis_light_gmm` %s (target "
            "for the best new estimator 0.25x: %s) | `bench/reproduce.sh render_room` (`build/bsdfmix render "
            "configs/render/<fiber>_room.yaml`), `scripts/guide_targets.py` ([CSVs](bench/results/render/), "
            "docs/render.md) |" % (span(ratio("guided")), span(ratio("guided_product")), span(ratio("mis_light_gmm")),
                                   "met" if all(x["best"] <= 0.25 for x in r) else "missed"))


def constant():
    import converge_targets
    csvs = [os.path.join(RESULTS, "converge", "%s_convergence.csv" % m) for m in ("polyester", "cotton")]
    r = [x for x in converge_targets.targets(csvs, converge_targets.tails_of(csvs), 1024) if x["scene"] == "constant"]
    cost = [x[c] for x in r for c in ("cost_is", "cost_mis", "cost_isgmm")]
    return ("| importance sampling, constant lighting, polyester and cotton at 0/30/60 degrees | `mis_tab` reaches "
            "`us_tab`'s error at 1024 samples with %s fewer samples, %s less time; a mixture sample costs %s a uniform "
            "one | `build/bsdfmix run configs/converge_polyester.yaml` (and `converge_cotton`), "
            "`scripts/converge_targets.py` ([CSVs](bench/results/converge/), docs/sampling.md) |" % (
                span([x["mis_fewer"] for x in r]), span([x["mis_time"] for x in r]), span(cost)))


def with_machine(row, *files):
    """The row with the machine its files were made on appended to its last column."""
    return row[:-2] + made_on(*files) + " |"


def markdown():
    """The table, as lines."""
    light = ["converge_light/%s_convergence.csv" % m for m in ("polyester", "cotton", "satin", "paper")]
    cloth_files = ["render/%s_%s/render.csv" % (f, s) for s in ("sky", "skymap")
                   for f in ("silk", "cotton", "wool", "polyester")]
    sweep = fit_sweep()
    return ["| what | result | reproduce |", "|---|---|---|", with_machine(em(), em_file(50)),
            with_machine(sweep[0], "fit_sweep.csv"), sweep[1],
            with_machine(search(), "search_compare.csv", "search_compare_polyester_best3.csv"),
            with_machine(before_after(), "search_before_after.csv", "search_time.csv"),
            with_machine(stand_in(), "rgb_stand_in.csv", "rgb_stand_in_no_copies.csv", "rgb_refine.csv"),
            with_machine(smallest(), "stand_in_bytes.csv"),
            with_machine(compact_tables.readme_row(), "compact_rivals.csv", "compact_rivals_image.csv"),
            with_machine(lighting(), *light),
            with_machine(cloth(), *cloth_files),
            with_machine(room(), *["render/%s_room/render.csv" % f for f in ("silk", "cotton", "wool", "polyester")]),
            with_machine(constant(), "converge/polyester_convergence.csv", "converge/cotton_convergence.csv")]
