#!/usr/bin/python3
"""Writes the results tables of README.md and docs/ from the committed CSVs under
bench/results/, between markers:

    <!-- table: NAME -->
    | ... the table, as this script writes it ... |
    <!-- /table -->

    scripts/doc_tables.py           rewrite every marked table in place
    scripts/doc_tables.py --check   exit 1, naming each table that differs from what its CSV gives

The tables (NAME: CSV):
  rgb_stand_in         bench/results/rgb_stand_in.csv (docs/fitting.md, "Colour and energy")
  rgb_copies           bench/results/rgb_stand_in{,_no_copies}.csv (docs/studies/colour.md, "Colour copies in
                       detail")
  rgb_refine           bench/results/rgb_refine.csv (docs/studies/colour.md, "The channels in the refinement")
  catalog              bench/results/catalog_summary.csv (docs/scale.md, "Catalogs")
  scale, scale_traffic bench/results/scale_amd-epyc-2c.csv (docs/studies/scale_measured.md, "Scaling measured")
  stand_in_smallest    bench/results/stand_in_bytes.csv (docs/studies/stand_in_bytes.md, "The smallest at 5 %")
  search_before_after  bench/results/search_before_after.csv (CHANGELOG.md, "A walk that does not give up")
  search_unseen        bench/results/search_unseen.csv (CHANGELOG.md, the same section)
  search_time          bench/results/search_time.csv (CHANGELOG.md, the same section)
  pinned_k             bench/results/pinned_k.csv (docs/studies/satin_grazing.md)
  tails                bench/results/tails.csv (docs/studies/satin_grazing.md, "Heavier tails")
  parameterization     bench/results/parameterization.csv (docs/studies/parameterization.md)
  map_accuracy         bench/results/map_accuracy.csv (docs/fitting.md, "The map and the base")
  map_choice           bench/results/map_choice.csv (docs/fitting.md, "The map and the base")
  renderer_chi2        bench/results/renderer_chi2{,_theta_phi}.csv (docs/sampling.md, "A renderer's sampling test")
  render_measured      bench/results/render/*/render.json (docs/render.md, "Measured materials")
  render_rgl           bench/results/render/<material>_skymap/render.csv (docs/studies/render_materials.md,
                       "The file's own sampler against the mixtures, in the image"): the RGL file's own
                       sampler against the mixtures and the table CDF
  render_cloth         bench/results/render/<fiber>_<scene>/ (docs/studies/render_cloth.md, "The measured renders"), by
                       scripts/render_tables.py
  render_reading       the same renders' reading (docs/render.md, "Measured"), by scripts/render_tables.py
  render_room          bench/results/render/<fiber>_room/ (docs/studies/render_guided.md, "In the room"), by
                       scripts/room_tables.py
  render_room_reading  the room renders' reading under that table, by scripts/room_tables.py
  failure_map, stability  bench/results/failure_map.csv (docs/studies/failure_map.md,
                       docs/studies/stability_cases.md), by scripts/failure_tables.py
  search_compare       bench/results/search_compare.csv (CHANGELOG.md, "Before and after")
  amplitude_objective  bench/results/amplitude_objective.csv (docs/studies/colour.md, "The objective")
  converge_refine      bench/results/converge_refine/satin_refine_{l1,none}_tail.csv (CHANGELOG.md,
                       "Before and after")
  em_precision         bench/results/em_precision.csv (docs/em.md, "Kernel vs reference")
  em_performance, fit_speed  bench/results/em_k*_<machine>.csv, em_speed.csv, fit_speed.csv (docs/em.md,
                       "Performance"), by scripts/em_tables.py
  fit_phases           bench/results/fit_speed.csv (docs/studies/em_kernels.md, "Where a fit's time goes"),
                       by scripts/em_tables.py
  mixed_devices        bench/results/mixed_devices.csv (docs/studies/em_kernels.md, "Devices of different speeds: the
                       mixed run")
  theta_border         bench/results/theta_border.csv (docs/studies/theta_border.md)
  em_results           the newest bench/results/em_k{50,16}_<machine>.csv (bench/README.md, "Results"), by
                       scripts/em_tables.py
  readme_measured      the README's results table, row by row from its CSVs (scripts/readme_measured.py)
  estimator_choice     docs/guide_estimators.md's decision table, by scripts/guide_tables.py
  converge             bench/results/converge/*_convergence{,_tail}.csv (docs/sampling.md, "Measured
                       results"), by scripts/converge_tables.py
  converge_light       bench/results/converge_light/*_convergence*.csv (docs/studies/sampling_lighting.md,
                       "The table"), by scripts/light_tables.py
  fiber_quadrature     bench/results/fiber_quadrature.csv (docs/studies/fiber_quadrature.md), by
                       scripts/input_tables.py
  fiber_generate       bench/results/fiber_generate.csv (docs/fiber.md), by scripts/input_tables.py
  cells_scale          bench/results/cells_scale.csv (docs/studies/cells_scale.md), by scripts/input_tables.py
  rgl_albedo, rgl_grid_error, rgl_reciprocity
                       bench/results/rgl_albedo.csv (docs/studies/rgl_albedo.md), by scripts/input_tables.py
  sampling_peers, sampling_peers_sky, sampling_peers_fiber
                       bench/results/sampling_peers.csv (sampling_peers in docs/sampling.md, "Against the
                       file's own sampler"; the others in docs/studies/sampling_peers.md)
  compact_rivals, compact_rivals_budgets, compact_rivals_cost, compact_rivals_image
                       bench/results/compact_rivals{,_image}.csv (docs/studies/compact_rivals.md; compact_rivals
                       under "At 8 KiB"), by
                       scripts/compact_tables.py
  interpolation        bench/results/interpolation.csv (docs/studies/sampling_interpolation.md), by
                       scripts/lobe_tables.py
  rgl_resolve          bench/results/rgl_resolve.csv (docs/studies/rgl_resolve.md), by
                       scripts/lobe_tables.py
  rgl_negative         bench/results/rgl_negative.csv (docs/studies/rgl_negative.md)
  render_material      bench/results/render_material.csv (docs/studies/render_materials.md, "What limits
                       the glossy spheres"), by scripts/lobe_tables.py
  render_4d            bench/results/render_4d.csv (docs/studies/render_4d.md), by
                       scripts/render_4d_tables.py
"""
import json
import math
import os
import re
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RESULTS = os.path.join(ROOT, "bench", "results")
DOCS = ["README.md", "CHANGELOG.md", os.path.join("bench", "README.md")] + [
    os.path.join(folder, f) for folder in ("docs", os.path.join("docs", "studies"))
    if os.path.isdir(os.path.join(ROOT, folder))
    for f in sorted(os.listdir(os.path.join(ROOT, folder))) if f.endswith(".md")]


sys.path.insert(0, os.path.join(ROOT, "scripts"))
from readme_measured import pct, rows  # noqa: E402  (the one reader and percent format of the tables)
import input_tables  # noqa: E402
import compact_tables  # noqa: E402
import lobe_tables  # noqa: E402
import render_4d_tables  # noqa: E402


def rgb_stand_in():
    names = {"satin": "satin_rosaline", "paper": "paper_white", "sunflower": "cg_sunflower",
             "iris": "cc_iris_purple_gem", "silk": "silk (fiber)",
             "cotton": "cotton (fiber)", "polyester": "polyester (fiber, dyed red)", "wool": "wool (fiber)"}
    out = ["| table | luminance L1 median | RGB error median | RGB error less the negative part, median | ratio "
           "to the luminance L1 | largest energy error, Y / R / G / B | largest difference, reported - "
           "recomputed l1_rel |", "|---|---|---|---|---|---|---|"]
    by = {r["table"]: r for r in rows("rgb_stand_in.csv")}
    for key, label in names.items():
        if key not in by:
            continue
        r = by[key]
        ratio = float(r["ratio"])
        energy = max(float(r["energy_max_" + c]) for c in "yrgb")
        e = "%.0e" % energy
        if int(r["noise_channels"]) > 0:
            e += " (channels that are not noise; %s of %s (slice, channel) pairs are, not compared)" % (
                r["noise_channels"], 3 * int(r["slices"]))
        out.append("| %s | %s | %s | %s | %s | %s | %.0e points |" % (
            label, pct(r["l1_median"]), pct(r["rgb_median"]), pct(r["rgb_less_negative_median"]),
            "%.3fx" % ratio, e, float(r["l1_diff_points"])))
    return out


def rgb_copies():
    names = {"satin": "satin_rosaline", "paper": "paper_white", "sunflower": "cg_sunflower",
             "iris": "cc_iris_purple_gem", "silk": "silk (fiber)", "cotton": "cotton (fiber)",
             "polyester": "polyester (fiber, dyed red)", "wool": "wool (fiber)"}
    out = ["| table | slices with copies | RGB error less the negative part, median: without / with copies | "
           "ratio to the luminance L1 median: without / with | luminance L1 median: without / with | "
           "fit seconds: without / with |", "|---|---|---|---|---|---|"]
    with_ = {r["table"]: r for r in rows("rgb_stand_in.csv")}
    without = {r["table"]: r for r in rows("rgb_stand_in_no_copies.csv")}
    for key, label in names.items():
        if key not in with_ or key not in without:
            continue
        a, b = without[key], with_[key]
        ratio = float(b["ratio"])
        out.append("| %s | %s of %s | %s / %s | %.3fx / %s | %s / %s | %.1f / %.1f |" % (
            label, b["copied_slices"], b["slices"], pct(a["rgb_less_negative_median"]),
            pct(b["rgb_less_negative_median"]), float(a["ratio"]), "%.3fx" % ratio,
            pct(a["l1_median"]), pct(b["l1_median"]), float(a["fit_seconds"]), float(b["fit_seconds"])))
    return out


def stand_in_smallest():
    every = {"1": "every row", "2": "every 2nd", "4": "every 4th"}
    out = ["| material | grid | slices fitted | K max | storage | bytes | file bytes | median / p90 RGB error | "
           "median L1 | largest energy error |", "|---|---|---|---|---|---|---|---|---|---|"]
    all_rows = rows("stand_in_bytes.csv")
    for m in ("satin_rosaline", "paper_white", "cg_sunflower"):
        ok = sorted((r for r in all_rows if r["material"] == m and float(r["median_rgb_error"]) <= 0.05),
                    key=lambda r: int(r["bytes"]))
        if not ok:
            out.append("| %s | | none at 5%% or less in this grid | | | | | | | |" % m)
            continue
        r = ok[0]
        out.append("| %s | %s | %s (%s) | %s | %s | %s | %s | %s / %s | %s | %.2g%% |" % (
            m, r.get("grid") or "%sx90x180" % r["rows"], every.get(r["every"], "every %s" % r["every"]),
            r["slices_fitted"], r["k_max"], r["storage"], r["bytes"], r["file_bytes"],
            pct(r["median_rgb_error"]), pct(r["p90_rgb_error"], 1), pct(r["median_l1"]),
            100 * float(r["max_energy_error"])))
    return out


def search_before_after(name="search_before_after.csv"):
    """Before / after per table; with `after_walk` rows (the after build, colour work off),
    before / the walk alone / after."""
    label = {"hard": "hard (bench/hard_table.py)", "satin": "satin_rosaline", "paper": "paper_white",
             "sunflower": "cg_sunflower", "iris": "cc_iris_purple_gem", "polyester_thesis": "polyester, thesis-scale"}
    by = {}
    for r in rows(name):
        by.setdefault(r["table"], {})[r["build"]] = r
    walk = all("after_walk" in b for b in by.values())
    builds = ["before", "after_walk", "after"] if walk else ["before", "after"]
    head = "before / walk / after" if walk else "before / after"
    out = ["| table | mean K, %s | L1 median | L1 p90 | L1 max | fit time, %s |" % (
               head, "walk / before, after / before" if walk else "after / before"), "|---|---|---|---|---|---|"]
    for t, b in by.items():
        time = ", ".join("%.2fx" % (float(b[x]["seconds"]) / float(b["before"]["seconds"])) for x in builds[1:])
        out.append("| %s | %s | %s | %s | %s | %s |" % (
            label.get(t, t), " / ".join("%.2f" % float(b[x]["mean_k"]) for x in builds),
            *(" / ".join(pct(b[x][c]) for x in builds) for c in ("l1_median", "l1_p90", "l1_max")), time))
    return out


def pinned_k():
    """Satin's grazing slices: the default search and pinned K, and where the default's error lies."""
    out = ["| theta_o | default search: K, L1 | pinned K 8 / 16 / 32 | default's error within 10 deg of the peak's "
           "phi (that band's share of the mass) | past theta_i 85 deg |", "|---|---|---|---|---|"]
    by = {}
    for r in rows("pinned_k.csv"):
        by.setdefault(int(r["slice"]), {})[r["setting"]] = r
    for s, b in sorted(by.items()):
        d = b["default"]
        out.append("| %.1f deg | %s, %s | %s | %s (%s) | %s |" % (
            math.degrees(float(d["theta_o"])), d["k"], pct(d["l1_rel"], 1),
            " / ".join(pct(b[k]["l1_rel"], 1) for k in ("k8", "k16", "k32")), pct(d["l1_peak"], 1),
            pct(d["mass_peak"], 0), pct(d["l1_horizon"], 1)))
    return out


def k_cells(fits):
    """A map's or fit's L1 at each K of parameterization.py's rows, in K order: "a / b / c"."""
    fits = sorted(fits or [], key=lambda r: int(r["k"]))
    return " / ".join(pct(r["l1_rel"], 1) if float(r["l1_rel"]) < 1 else "> 100%" for r in fits) or "-"


def tails():
    """Satin's grazing slices: plain EM's L1 at K 4 / 8 / 16 with Gaussians and Student-t components."""
    out = ["| theta_o | plain EM, Gaussians | Student-t, 3 degrees of freedom | Student-t, 10 |", "|---|---|---|---|"]
    by = {}
    for r in rows("tails.csv"):
        by.setdefault(int(r["row"]), {}).setdefault(r["map"], []).append(r)
    for row, maps in sorted(by.items()):
        out.append("| %.1f deg | %s | %s | %s |" % (math.degrees(float(maps["native"][0]["theta_o"])),
                                                   *(k_cells(maps.get(m)) for m in ("native", "native_t3", "native_t10"))))
    return out


def parameterization():
    """Per table and row: plain EM's L1 in each map at K 4 / 8 / 16, the project's fits in
    (theta, phi) and on the disk beside."""
    out = ["| table | theta_o | plain EM, (theta, phi) | plain EM, equal-area disk | plain EM, half vector | "
           "the project's fit pinned at K, (theta, phi) | the project's fit pinned at K, disk | "
           "the project's default (K), (theta, phi) / disk |", "|---|---|---|---|---|---|---|---|"]
    by = {}
    for r in rows("parameterization.csv"):
        by.setdefault((r["table"], int(r["row"])), {}).setdefault(r["map"], []).append(r)

    def default(maps, label):
        d = maps.get(label, [{}])[0]
        return "%s (%s)" % (pct(d["l1_rel"], 1), d["k"]) if d else "-"

    for (table, row), maps in by.items():
        out.append("| %s | %.1f deg | %s | %s | %s | %s | %s | %s / %s |" % (
            table, math.degrees(float(maps[next(iter(maps))][0]["theta_o"])), k_cells(maps.get("native")),
            k_cells(maps.get("disk")), k_cells(maps.get("half")), k_cells(maps.get("project")),
            k_cells(maps.get("project_disk")), default(maps, "project_default"), default(maps, "project_default_disk")))
    return out


def map_accuracy():
    """Per table: median L1 (mean K) of the fitted rows in each map, largest energy errors."""
    out = ["| table | (theta, phi) | equal-area map | largest energy error, (theta, phi) / map |", "|---|---|---|---|"]
    by = {}
    for r in rows("map_accuracy.csv"):
        by.setdefault(r["table"], {}).setdefault(r["map"], []).append(r)
    for table, maps in by.items():
        cell = {}
        for m, rr in maps.items():
            l1 = sorted(float(r["l1_rel"]) for r in rr)
            med = (l1[(len(l1) - 1) // 2] + l1[len(l1) // 2]) / 2
            cell[m] = ("%.2f%% (%.1f)" % (100 * med, sum(float(r["k"]) for r in rr) / len(rr)),
                       "%.1f%%" % (100 * max(abs(float(r["energy"])) for r in rr)))
        out.append("| %s | %s | %s | %s / %s |" % (table, cell["theta_phi"][0], cell["equal_area"][0],
                                                   cell["theta_phi"][1], cell["equal_area"][1]))
    return out


def map_choice():
    """Per RGL file: median / p90 L1 (mean K) and seconds of each map setting; auto's choice and probe."""
    out = ["| table | auto chose | auto | (theta, phi) | disk | seconds, auto / (theta, phi) / disk |",
           "|---|---|---|---|---|---|"]
    by = {}
    for r in rows("map_choice.csv"):
        by.setdefault(r["table"], {})[r["map"]] = r
    for table, m in by.items():
        def cell(r):
            return "%s / %s (%.1f)" % (pct(r["l1_median"]), pct(r["l1_p90"]), float(r["mean_k"]))
        a = m["auto"]
        out.append("| %s | %s | %s | %s | %s | %s / %s / %s |" % (
            table, "disk" if a["fitted"] == "disk" else "(theta, phi)", cell(a), cell(m["theta_phi"]),
            cell(m["equal_area"]), a["fit_seconds"], m["theta_phi"]["fit_seconds"], m["equal_area"]["fit_seconds"]))
    return out


def renderer_chi2():
    """Views passing Mitsuba 3's chi-square test per map, and with 16 x 16 quadrature nodes."""
    out = ["| fits | views | pass | pass with 16 x 16 nodes, pole rows out |", "|---|---|---|---|"]
    for name, label in (("renderer_chi2_theta_phi.csv", "(theta, phi)"), ("renderer_chi2.csv", "equal-area map")):
        rr = rows(name)
        alpha = 1 - (1 - 0.01) ** (1 / len(rr))
        passed = sum(r["passed"] in ("1", "True", "true") for r in rr)
        fine = sum(float(r["p_value_no_pole_rows_ires16"]) >= alpha for r in rr) if label != "(theta, phi)" else None
        out.append("| %s | %d | %d | %s |" % (label, len(rr), passed, "-" if fine is None else str(fine)))
    return out


def render_measured():
    out = ["| table | stand-in bytes | difference, pixels / 4 x 4 blocks | the table image's own noise (4 x 4) | image "
           "mean, luminance / R / G / B |", "|---|---|---|---|---|"]
    for folder, label in (("satin_skymap", "satin_rosaline"), ("paper_skymap", "paper_white"),
                          ("sunflower_skymap", "cg_sunflower"), ("iris_skymap", "cc_iris_purple_gem"),
                          ("polyester_sky_small", "polyester cloth (sky)"),
                          ("satin_skymap_target2", "satin_rosaline, fitted to 2% L1"),
                          ("polyester_sky_small_target2", "polyester cloth (sky), fitted to 2% L1")):
        with open(os.path.join(RESULTS, "render", folder, "render.json")) as f:
            j = json.load(f)
        means = [j["stand_in_mean_difference"]] + list(j["stand_in_channel_mean_difference"])
        cells = [("**%+.2f%%**" if abs(m) > 0.005 else "%+.2f%%") % (100 * m) for m in means]
        out.append("| %s | %.0f KiB | %.2f%% / %.2f%% | %.2f%% | %s |" % (
            label, j["mixture_bytes"] / 1024, 100 * j["stand_in_difference"], 100 * j["stand_in_difference_4x4"],
            100 * j["table_noise_4x4"], " / ".join(cells)))
    return out


def render_rgl():
    """The RGL spheres under the sky map: each estimator's relative MSE at equal samples and at
    equal time (its samples per pixel), against mis_light_rgl's at equal time, and its ns per vertex."""
    out = ["| material | estimator | rel MSE, equal samples | rel MSE, equal time (spp) | equal time / mis_light_rgl | "
           "ns per vertex | ns per vertex / mis_light_cdf |", "|---|---|---|---|---|---|---|"]
    for folder, label in (("satin_skymap", "satin_rosaline"), ("iris_skymap", "cc_iris_purple_gem"),
                          ("paper_skymap", "paper_white"), ("sunflower_skymap", "cg_sunflower")):
        rs = rows(os.path.join("render", folder, "render.csv"))
        spp = {r["estimator"]: r for r in rs if r["mode"] == "equal_spp"}
        tim = {r["estimator"]: r for r in rs if r["mode"] == "equal_time"}
        if "mis_light_rgl" not in tim:
            continue
        base_t, base_ns = float(tim["mis_light_rgl"]["rel_mse"]), float(spp["mis_light_cdf"]["ns_per_vertex"])
        for e in ("mis_light_rgl", "is_rgl", "mis_light_cdf", "mis_light_gmm", "mis_product"):
            a, b = spp[e], tim[e]
            out.append("| %s | `%s` | %.3g | %.3g (%s) | %.2fx | %.0f | %.2fx |" % (
                label, e, float(a["rel_mse"]), float(b["rel_mse"]), b["spp"], float(b["rel_mse"]) / base_t,
                float(a["ns_per_vertex"]), float(a["ns_per_vertex"]) / base_ns))
    return out


def rgb_refine():
    names = {"satin": "satin_rosaline", "paper": "paper_white", "sunflower": "cg_sunflower", "silk": "silk",
             "cotton": "cotton", "polyester": "polyester (red)", "wool": "wool"}
    labels = {"alone": "the luminance alone (0, 5)", "default": "**the default (0.5, 5)**",
              "third": "a third (1/3, 5)", "l1x2": "the L1 part doubled (0.5, 2.5)",
              "l1x3": "the L1 part tripled (2/3, 5/3)"}
    out = ["| variant (refine_rgb, refine_kl) | table | luminance L1 median / p90 | RGB error less the negative part, "
           "median | ratio to the luminance L1 | mean K | chi-square: mean, median / p90 ratio to the luminance alone |",
           "|---|---|---|---|---|---|---|"]
    for r in rows("rgb_refine.csv"):
        ratio = float(r["ratio"])
        out.append("| %s | %s | %s / %s | %s | %s | %.2f | %.4f, %.3f / %.3f |" % (
            labels.get(r["variant"], r["variant"]), names.get(r["table"], r["table"]), pct(r["l1_median"]),
            pct(r["l1_p90"]), pct(r["rgb_less_negative_median"]), ("**%.3fx**" if ratio > 1.2 else "%.3fx") % ratio,
            float(r["mean_k"]), float(r["chi_mean"]), float(r["chi_ratio_median"]), float(r["chi_ratio_p90"])))
    return out


def catalog():
    out = ["| table | slices | mean K | L1 median | L1 p90 | table bytes | mixture bytes | seconds |",
           "|---|---|---|---|---|---|---|---|"]
    all_rows = rows("catalog_summary.csv")
    for r in all_rows:
        out.append("| %s | %s | %.2f | %s | %s | %s | %s | %.2f |" % (
            r["table"], r["slices"], float(r["mean_k"]), pct(r["l1_median"], 1), pct(r["l1_p90"], 1),
            r["table_bytes"], r["mixture_bytes"], float(r["seconds"])))
    out.append("| all | %d | | | | | | %.1f |" % (sum(int(r["slices"]) for r in all_rows),
                                                 sum(float(r["seconds"]) for r in all_rows)))
    return out


def scale_rows():
    return [r for r in rows("scale_amd-epyc-2c.csv")]


def scale():
    labels = {"1rank_1core": "`1rank_1core`", "2ranks_2cores": "`2ranks_2cores`", "1proc_2cores": "`1proc_2cores`",
              "2copies_2cores": "`2copies_2cores` (two independent 1-core fits at once)"}
    out = ["| config | fit time | slices/s | against 1 rank on 1 core |", "|---|---|---|---|"]
    for r in scale_rows():
        speed = float(r["speedup"])
        against = "1" if r["config"] == "1rank_1core" else "%.2fx" % speed
        if r["config"] == "2ranks_2cores":
            against += " (efficiency %.2f)" % float(r["efficiency"])
        seconds = "%.2f s per table" % float(r["fit_seconds"]) if r["config"] == "2copies_2cores" else \
            "%.2f s" % float(r["fit_seconds"])
        out.append("| %s | %s | %.1f | %s |" % (labels.get(r["config"], r["config"]), seconds,
                                                float(r["slices_per_s"]), against))
    return out


def scale_traffic():
    r = next(x for x in scale_rows() if x["config"] == "2ranks_2cores")
    slices = int(r["slices"]) // int(r["batches"])
    return ["| quantity | value |", "|---|---|",
            "| task (rank 0 -> worker) | %s B per batch (%d slices) |" % (r["bytes_out_per_remote_batch"], slices),
            "| part (worker -> rank 0) | %.2f kB per batch (%d slices, K <= 16) |" % (
                float(r["bytes_back_per_remote_batch"]) / 1000, slices),
            "| fitting | %.3f s per batch |" % float(r["compute_s_per_batch"]),
            "| committing on rank 0 (decode, part file written and synced) | %.2f ms per batch |" % (
                1000 * float(r["commit_s_per_batch"]))]


def render_reading():
    import render_tables
    return render_tables.reading([os.path.join(RESULTS, "render", "%s_%s" % (f, s))
                                   for s in ("sky", "skymap") for f in ("silk", "cotton", "wool", "polyester")])


def render_cloth():
    import render_tables
    return render_tables.markdown([os.path.join(RESULTS, "render", "%s_%s" % (f, s))
                                    for s in ("sky", "skymap") for f in ("silk", "cotton", "wool", "polyester")])


def room_dirs():
    return [os.path.join(RESULTS, "render", "%s_room" % f) for f in ("silk", "cotton", "wool", "polyester")]


def render_room():
    import room_tables
    return room_tables.markdown(room_dirs())


def render_room_reading():
    import room_tables
    return room_tables.reading(room_dirs())


def readme_measured():
    import readme_measured as m
    return m.markdown()


def search_compare():
    names = {"polyester": "polyester", "satin": "satin (RGL)", "paper": "paper (RGL)", "sunflower": "sunflower (RGL)"}
    methods = [("restarts", "none", "restarts (before)"), ("smem", "none", "smem, refine none"),
               ("smem", "l1", "smem + L1 refinement (after)")]
    by = {(r["table"], r["search"], r["refine"], r["run"]): r for r in rows("search_compare.csv")}
    out = ["| table | method | search: mean K | L1 median / p90 at the chosen K | search time (x before) | K = 8: L1 "
           "median / p90 | K = 16: L1 median / p90 | K = 8 / 16 time |", "|---|---|---|---|---|---|---|---|"]
    for t, label in names.items():
        if (t, "restarts", "none", "search") not in by:
            continue
        before = float(by[(t, "restarts", "none", "search")]["seconds"])
        for search, refine, method in methods:
            s, k8, k16 = (by[(t, search, refine, run)] for run in ("search", "k8", "k16"))
            out.append("| %s | %s | %.2f | %s / %s | %.1f s (%.2fx) | %s / %s | %s / %s | %.1f / %.1f s |" % (
                label, method, float(s["mean_k"]), pct(s["l1_median"]), pct(s["l1_p90"]), float(s["seconds"]),
                float(s["seconds"]) / before, pct(k8["l1_median"]), pct(k8["l1_p90"]), pct(k16["l1_median"]),
                pct(k16["l1_p90"]), float(k8["seconds"]), float(k16["seconds"])))
    return out


def theta_border():
    def span(xs, fmt):
        lo, hi = fmt(min(xs)), fmt(max(xs))
        return lo if lo == hi else "%s-%s" % (lo[:-1] if lo.endswith("%") else lo, hi)

    def pc(x):
        return "%.2g%%" % (100 * x)

    all_rows = rows("theta_border.csv")
    methods = [("restarts", "none"), ("smem", "none"), ("smem", "l1")]
    out = ["| c (sigma inside) | chosen K (true 3): restarts / smem / + L1 | l1_rel at the chosen K: restarts / smem / "
           "+ L1 | l1_rel of the true mixture as the stand-in | at K = 3, the fitted mean's shift (sigma) and sigma "
           "ratio: EM / + L1 |", "|---|---|---|---|---|"]
    for c in sorted({float(r["c"]) for r in all_rows}):
        here = [r for r in all_rows if float(r["c"]) == c]
        by = {m: [r for r in here if (r["search"], r["refine"]) == m] for m in methods}
        ks = " / ".join(span([int(r["k"]) for r in by[m]], str) for m in methods)
        l1 = " / ".join(span([float(r["l1_rel"]) for r in by[m]], pc) for m in methods)
        truth = span([float(r["true_l1_rel"]) for r in by[methods[0]]], pc)
        shapes = []
        for m in (("smem", "none"), ("smem", "l1")):
            at3 = [r for r in by[m] if r["mean_shift_sigma"]]
            shapes.append("-" if not at3 else "%s, %s (%d of %d)" % (
                span([float(r["mean_shift_sigma"]) for r in at3], lambda x: "%.2g" % x),
                span([float(r["sigma_ratio"]) for r in at3], lambda x: "%.2f" % x), len(at3), len(by[m])))
        out.append("| %s%s | %s | %s | %s | %s |" % ("%.1f" % c, " (mean on the border)" if c == 0 else "", ks, l1,
                                                    truth, " / ".join(shapes)))
    return out


def amplitude_objective():
    import statistics
    all_rows = rows("amplitude_objective.csv")
    med = lambda t, m, c: statistics.median(float(r[c]) for r in all_rows if r["table"] == t and r["method"] == m)
    trio = lambda t, m: " / ".join(pct(med(t, m, c)) for c in ("l1_rel", "rgb_l1_rel", "rgb_less_negative"))
    out = ["| material | least squares: luminance L1 / RGB / RGB less negative | reweighted (kept) | linear program | "
           "seconds per slice, reweighted / linear program |", "|---|---|---|---|---|"]
    for t, label in (("satin", "satin_rosaline"), ("paper", "paper_white"), ("sunflower", "cg_sunflower")):
        if not any(r["table"] == t for r in all_rows):
            continue
        out.append("| %s | %s | %s | %s | %.2f / %.0f |" % (label, trio(t, "ls"), trio(t, "irls"), trio(t, "lp"),
                                                          med(t, "irls", "seconds"), med(t, "lp", "seconds")))
    return out


def em_results():
    import em_tables
    import readme_measured
    machine = readme_measured.em_file(50)[len("em_k50_"):-len(".csv")]
    return em_tables.results(machine)


def converge_refine():
    l1 = rows(os.path.join("converge_refine", "satin_refine_l1_tail.csv"))
    em = {r["theta_o"]: r for r in rows(os.path.join("converge_refine", "satin_refine_none_tail.csv"))}
    out = ["| satin, theta_o (deg) | K: refined / EM | L1: refined / EM | predicted variance of `is_tab`, refined / EM "
           "| of `mis_tab` | stand-in's integral error: refined / EM |", "|---|---|---|---|---|---|"]
    for r in l1:
        e = em[r["theta_o"]]
        out.append("| %.0f | %s / %s | %s / %s | %.2fx | %.2fx | %.1e / %.1e |" % (
            math.degrees(float(r["theta_o"])), r["k"], e["k"], pct(r["l1_rel"], 1), pct(e["l1_rel"], 1),
            float(r["relvar_is"]) / float(e["relvar_is"]), float(r["relvar_mis"]) / float(e["relvar_mis"]),
            float(r["stand_in_error"]), float(e["stand_in_error"])))
    return out


def em_precision():
    by = {r["precision"]: r for r in rows("em_precision.csv")}
    a, b = by.get("auto"), by.get("fp32")
    out = ["| quantity | precision auto (fp64 on a CPU), max | fp32, max | test bound |", "|---|---|---|---|"]
    for key, label, bound in (("loglik_abs", "final log-likelihood, absolute (x max(1, \\|L\\|))", "2e-5"),
                              ("weight_abs", "weights, absolute", "2e-5"), ("mean_rad", "means, rad", "5e-5"),
                              ("cov_rel", "covariances, relative to sqrt(s_tt s_pp)", "5e-4")):
        sci = lambda x: "%.1fe%d" % (float("%.1e" % x) / 10 ** math.floor(math.log10(float("%.1e" % x))),
                                     math.floor(math.log10(float("%.1e" % x)))) if x > 0 else "0"
        out.append("| %s | %s | %s | %s |" % (label, sci(float(a[key])), sci(float(b[key])), bound))
    out.append("| iterations equal to the reference's | %s of %s | %s of %s | all |" % (
        a["iterations_equal"], a["fits"], b["iterations_equal"], b["fits"]))
    return out


def mixed_devices():
    out = ["| devices | sweep | best of | wall time | over PoCL alone | oclgrind's runs, calibration included (seconds) | slices whose K differ | largest L1 difference | machine |",
           "|---|---|---|---|---|---|---|---|---|"]
    for r in rows("mixed_devices.csv"):
        out.append("| %s | %s silk slices of %s, K up to 16 | %s | %.1f s | %.3fx | %s (%s s) | %s | %s | %s, %s cores |" % (
            r["setup"], r["slices"], r["grid"].replace("x", " x "), r["runs"], float(r["best_seconds"]),
            float(r["over_pocl"]), r["oclgrind_runs"], r["oclgrind_seconds"], r["slices_k_differ"],
            "%.2g" % float(r["max_l1_difference"]), r["cpu_model"], r["logical_cpus"]))
    return out


def rgl_negative():
    out = ["| material | cells with a negative channel | luminance raised by clipping, median over those cells | largest, one cell | albedo raised, median over slices | largest |",
           "|---|---|---|---|---|---|"]
    for r in rows("rgl_negative.csv"):
        out.append("| %s | %.1f%% | %.2f%% | %.1f%% | %.2f%% | %.2f%% |" % (
            r["material"], 100 * float(r["negative_share"]), 100 * float(r["median_rel_y_difference_negative_cells"]),
            100 * float(r["max_rel_y_difference"]), 100 * float(r["median_albedo_difference"]),
            100 * float(r["max_albedo_difference"])))
    return out


def em_builds():
    out = ["| K | slices of 90 x 180 | before, s per iteration | this build | this build over before | device | machine |",
           "|---|---|---|---|---|---|---|"]
    for r in rows("em_builds.csv"):
        out.append("| %s | %s | %.5f | %.5f | %.3fx | %s | %s, %s cores |" % (
            r["k"], r["slices"], float(r["before_s_per_iter"]), float(r["after_s_per_iter"]),
            float(r["after_over_before"]), r["device"], r["cpu_model"], r["logical_cpus"]))
    return out


def estimator_choice():
    import guide_tables
    return guide_tables.choice()


def failure_map():
    import failure_tables
    return failure_tables.readme()


def stability():
    import failure_tables
    return failure_tables.stability()


def converge():
    import converge_tables
    return converge_tables.markdown([os.path.join(RESULTS, "converge", "%s_convergence.csv" % m)
                                      for m in ("polyester", "cotton", "satin")])


def converge_light():
    import light_tables
    return light_tables.markdown([os.path.join(RESULTS, "converge_light", "%s_convergence.csv" % m)
                                   for m in ("polyester", "cotton", "satin", "paper")])


def _peers(lighting):
    """sampling_peers.csv's rows under `lighting`: material -> view -> sampler -> row."""
    by = {}
    for r in rows("sampling_peers.csv"):
        if r.get("lighting", "constant") == lighting:
            by.setdefault(r["material"], {}).setdefault(r["theta_o_deg"], {})[r["sampler"]] = r
    return by


def _median(x):
    x = sorted(x)
    return x[len(x) // 2] if len(x) % 2 else 0.5 * (x[len(x) // 2 - 1] + x[len(x) // 2])


def _ratio_cell(views, s, ref):
    """The variance per sample of sampler s over ref's, median over the views (largest)."""
    x = [float(v[s]["relvar"]) / float(v[ref]["relvar"]) for v in views]
    return "%.3g (%.3g)" % (_median(x), max(x))


def sampling_peers():
    """Per RGL material under constant light: each sampler's variance per sample over the
    file's own sampler's, median and largest over the views; the largest weights; the bytes."""
    by = {m: v for m, v in _peers("constant").items() if all("rgl" in x for x in v.values())}
    out = ["| material | file's own sampler: variance per sample, median (largest) | mixture alone / file's, median "
           "(largest) | mixture + earned share / file's | table CDF / file's | uniform / file's | largest weight / I: "
           "file's, mixture + earned share | bytes: mixture, file, table |", "|---|---|---|---|---|---|---|---|"]
    f = lambda x: "%.3g" % x
    for mat in sorted(by):
        views = list(by[mat].values())
        own = [float(v["rgl"]["relvar"]) for v in views]
        wmax = lambda s: max(float(v[s]["max_weight_over_integral"]) for v in views)
        b = views[0]
        out.append("| %s | %s (%s) | %s | %s | %s | %s | %s, %s | %s, %s, %s |" % (
            mat, f(_median(own)), f(max(own)), _ratio_cell(views, "is_mixture", "rgl"),
            _ratio_cell(views, "mis_mixture", "rgl"), _ratio_cell(views, "cdf_table", "rgl"),
            _ratio_cell(views, "uniform", "rgl"), f(wmax("rgl")), f(wmax("mis_mixture")), b["is_mixture"]["bytes"],
            b["rgl"]["bytes"], b["cdf_table"]["bytes"]))
    return out


_SKY_SAMPLERS = [("mis_light_rgl", "`mis_light_rgl`: light 50 % + the file's warps"),
                 ("rgl", "`is_rgl`: the file's warps alone"),
                 ("light", "`light`: light sampling alone"),
                 ("mis_light_cdf", "`mis_light_cdf`: light 50 % + table CDF"),
                 ("mis_light_gmm", "`mis_light_gmm`: light 50 % + mixture with earned share"),
                 ("product", "`product`: mixture x lighting mixture"),
                 ("mis_product", "`mis_product`: product + light + uniform"),
                 ("is_mixture", "`is_tab`: the mixture alone"),
                 ("mis_mixture", "`mis_tab`: mixture + earned share"),
                 ("cdf_table", "`cdf_tab`: the table CDF"),
                 ("uniform", "uniform")]


def sampling_peers_sky():
    """Per RGL material under the sky: each sampler's variance per sample over mis_light_rgl's,
    median (largest) over the views; mis_light_rgl's own variance per sample first."""
    by = {m: v for m, v in _peers("sky").items() if all("mis_light_rgl" in x for x in v.values())}
    mats = sorted(by)
    out = ["| sampler | " + " | ".join(mats) + " |", "|---" * (len(mats) + 1) + "|"]
    for s, label in _SKY_SAMPLERS:
        if s == "mis_light_rgl":
            cells = []
            for m in mats:
                x = [float(v[s]["relvar"]) for v in by[m].values()]
                cells.append("%.3g (%.3g)" % (_median(x), max(x)))
            out.append("| %s: variance per sample, median (largest) | %s |" % (label, " | ".join(cells)))
        else:
            out.append("| %s / `mis_light_rgl` | %s |" % (
                label, " | ".join(_ratio_cell(list(by[m].values()), s, "mis_light_rgl") for m in mats)))
    return out


def sampling_peers_fiber():
    """Per fiber preset (f the table): each sampler's variance per sample, median (largest)
    over the views, under constant light and the sky; mis_tab over cdf_tab under the sky."""
    const, sky = _peers("constant"), _peers("sky")
    fibers = [m for m in ("silk", "cotton", "polyester", "wool") if m in const and m in sky]
    out = ["| lighting | sampler | " + " | ".join(fibers) + " |", "|---|---" + "|---" * len(fibers) + "|"]
    for lighting, by in (("constant", const), ("sky", sky)):
        for s, label in _SKY_SAMPLERS:
            if s not in next(iter(by[fibers[0]].values())):
                continue
            cells = []
            for m in fibers:
                x = [float(v[s]["relvar"]) for v in by[m].values()]
                cells.append("%.3g (%.3g)" % (_median(x), max(x)))
            out.append("| %s | %s | %s |" % (lighting, label, " | ".join(cells)))
    out.append("| sky | `mis_tab` / `cdf_tab` | %s |" % " | ".join(
        _ratio_cell(list(sky[m].values()), "mis_mixture", "cdf_table") for m in fibers))
    out.append("| sky | `mis_product` / `cdf_tab` | %s |" % " | ".join(
        _ratio_cell(list(sky[m].values()), "mis_product", "cdf_table") for m in fibers))
    out.append("| | bytes: mixture, table | %s |" % " | ".join(
        "%s, %s" % (next(iter(const[m].values()))["is_mixture"]["bytes"],
                    next(iter(const[m].values()))["cdf_table"]["bytes"]) for m in fibers))
    return out


TABLES = {"sampling_peers": sampling_peers, "sampling_peers_sky": sampling_peers_sky,
          "sampling_peers_fiber": sampling_peers_fiber, "rgb_stand_in": rgb_stand_in, "rgb_copies": rgb_copies, "rgb_refine": rgb_refine, "catalog": catalog, "scale": scale,
          "scale_traffic": scale_traffic, "stand_in_smallest": stand_in_smallest,
          "search_before_after": search_before_after, "render_measured": render_measured,
          "render_rgl": render_rgl,
          "render_cloth": render_cloth, "render_room": render_room, "render_room_reading": render_room_reading,
          "converge": converge, "converge_light": converge_light,
          "readme_measured": readme_measured, "estimator_choice": estimator_choice, "failure_map": failure_map, "stability": stability,
          "search_compare": search_compare, "amplitude_objective": amplitude_objective,
          "em_results": em_results, "converge_refine": converge_refine,
          "em_performance": lambda: __import__("em_tables").performance(),
          "fit_speed": lambda: __import__("em_tables").fit_speed(),
          "fit_phases": lambda: __import__("em_tables").fit_phases(),
          "theta_border": theta_border,
          "em_precision": em_precision, "mixed_devices": mixed_devices, "em_builds": em_builds,
          "rgl_negative": rgl_negative,
          "render_reading": render_reading,
          "search_unseen": lambda: search_before_after("search_unseen.csv"),
          "search_time": lambda: search_before_after("search_time.csv"), "pinned_k": pinned_k, "tails": tails,
          "parameterization": parameterization, "map_accuracy": map_accuracy, "map_choice": map_choice, "renderer_chi2": renderer_chi2,
          "fiber_quadrature": input_tables.fiber_quadrature,
          "fiber_generate": input_tables.fiber_generate, "cells_scale": input_tables.cells_scale,
          "rgl_albedo": input_tables.rgl_albedo,
          "rgl_grid_error": input_tables.rgl_grid_error, "rgl_reciprocity": input_tables.rgl_reciprocity,
          "compact_rivals": compact_tables.at_8k, "compact_rivals_budgets": compact_tables.budgets,
          "compact_rivals_cost": compact_tables.cost, "compact_rivals_image": compact_tables.image,
          "interpolation": lobe_tables.interpolation, "rgl_resolve": lobe_tables.rgl_resolve,
          "render_material": lobe_tables.render_material, "render_4d": render_4d_tables.table}
MARKER = re.compile(r"(<!-- table: (\w+) -->\n)(.*?)(<!-- /table -->)", re.S)


def main():
    check = "--check" in sys.argv[1:]
    if any(a not in ("--check",) for a in sys.argv[1:]):
        sys.exit(__doc__)
    stale, seen = [], set()
    for doc in DOCS:
        path = os.path.join(ROOT, doc)
        with open(path) as f:
            text = f.read()

        def fill(m):
            name = m.group(2)
            if name not in TABLES:
                sys.exit("%s: unknown table '%s' (scripts/doc_tables.py --help)" % (doc, name))
            seen.add(name)
            body = "\n".join(TABLES[name]()) + "\n"
            if body != m.group(3):
                stale.append("%s: table '%s'" % (doc, name))
            return m.group(1) + body + m.group(4)

        new = MARKER.sub(fill, text)
        if not check and new != text:
            with open(path + ".tmp", "w") as f:
                f.write(new)
            os.replace(path + ".tmp", path)
    missing = sorted(set(TABLES) - seen)
    if missing:
        sys.exit("doc_tables: no marker for %s in README.md, bench/README.md or docs/" % ", ".join(missing))
    if check and stale:
        for s in stale:
            print("doc_tables: %s differs from its CSV (run scripts/doc_tables.py)" % s, file=sys.stderr)
        sys.exit(1)
    if not check:
        print("doc_tables: %d table(s) written, %d changed" % (len(seen), len(stale)))


if __name__ == "__main__":
    main()
