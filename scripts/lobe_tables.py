"""Doc tables of how the mixtures follow lobes (scripts/doc_tables.py): interpolation
between slices (bench/results/interpolation.csv), the grids that resolve sharp lobes
(bench/results/rgl_resolve.csv), and the glossy spheres' light-sampling estimators on the
sphere's own pixels (bench/results/render_material.csv)."""
import csv
import os

RESULTS = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "bench", "results")


def rows(name):
    path = os.path.join(RESULTS, name)
    if not os.path.exists(path):
        return []
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def interpolation():
    by = {}
    for r in rows("interpolation.csv"):
        by.setdefault(r["material"], {})[r["interpolation"]] = r
    out = ["| material | left-out slices: L1, median (p90), blend | displace | mixture / file's sampler, median (largest) of %s views: blend | displace |"
           % next(iter(by.values()))["blend"]["views"] if by else "| material |",
           "|---|---|---|---|---|"]
    for m, d in sorted(by.items()):
        b, x = d["blend"], d["displace"]
        out.append("| %s | %.2f%% (%.2f%%) | %.2f%% (%.2f%%) | %s (%s) | %s (%s) |" % (
            m, 100 * float(b["l1_left_out_median"]), 100 * float(b["l1_left_out_p90"]),
            100 * float(x["l1_left_out_median"]), 100 * float(x["l1_left_out_p90"]),
            b["is_mixture_over_rgl_median"], b["is_mixture_over_rgl_max"],
            x["is_mixture_over_rgl_median"], x["is_mixture_over_rgl_max"]))
    return out


def rgl_resolve():
    label = {"default": "default", "resolved": "resolved", "resolved_t2": "resolved, fit to 2 % L1",
             "resolved_t2_theta_o_x2": "resolved, 2 % L1, 2x the theta_o slices",
             "resolved_t2_theta_i_x4": "resolved, 2 % L1, 4x the theta_i cells",
             "resolved_t2_phi_i_1440": "resolved, 2 % L1, phi_i at its cap",
             "resolved_t2_k64": "resolved, 2 % L1, K up to 64"}
    out = ["| material | narrowest lobe, degrees (theta x across), at view | grid | table MiB | fit L1, median | fit seconds | mixture bytes | "
           "mixture / file's sampler, median (largest) | views over 3x | at the worst view: its elevation, table CDF / file's | "
           "table CDF / file's, median (largest) |",
           "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows("rgl_resolve.csv"):
        measured = r["is_mixture_over_rgl_median"] != ""
        l1 = r.get("fit_l1_median", "")
        out.append("| %s | %s x %s at %s | %s: %s x %s x %s | %s | %s | %s | %s | %s | %s | %s | %s |" % (
            r["material"], r["lobe_fwhm_theta_deg"], r["lobe_fwhm_across_deg"], r["lobe_at_theta_o_deg"],
            label.get(r["grid"], r["grid"]), r["theta_o"], r["theta_i"], r["phi_i"], r["table_mib"],
            "%.1f%%" % (100 * float(l1)) if l1 else "-", "%.0f" % float(r["fit_seconds"]) if r.get("fit_seconds") else "-",
            r["mixture_bytes"] or "-",
            "%s (%s)" % (r["is_mixture_over_rgl_median"], r["is_mixture_over_rgl_max"]) if measured else "not imported",
            "%s of %s" % (r["views_over_3x"], r["views"]) if measured else "-",
            "%s deg, %s" % (r["worst_view_deg"], r["cdf_table_over_rgl_at_worst"]) if measured else "-",
            "%s (%s)" % (r["cdf_table_over_rgl_median"], r["cdf_table_over_rgl_max"]) if measured else "-"))
    return out


def render_material():
    """Per glossy sphere and lighting: mis_light_rgl's relative MSE on the sphere's pixels at
    equal samples, and each other estimator's over it at equal samples and at equal time."""
    lighting = {"skymap": "sky map, over the ground", "skymap_no_ground": "sky map, no ground",
                "sky_no_ground": "analytic sky, no ground"}
    names = {"satin": "satin_rosaline", "iris": "cc_iris_purple_gem"}
    by = {}
    for r in rows("render_material.csv"):
        by.setdefault((r["material"], r["variant"]), {})[(r["estimator"], r["mode"])] = r
    est = ("mis_light_cdf", "mis_light_gmm", "mis_product")
    out = ["| material | lighting | `mis_light_rgl`: rel MSE on the sphere, equal samples (whole image) | " +
           " | ".join("`%s` / `mis_light_rgl` on the sphere: equal samples, equal time" % e for e in est) + " |",
           "|---|---|---|" + "---|" * len(est)]
    for (m, v), d in by.items():
        base = d[("mis_light_rgl", "equal_spp")]
        out.append("| %s | %s | %.3g (%.3g) | %s |" % (
            names.get(m, m), lighting.get(v, v), float(base["rel_mse_material"]), float(base["rel_mse"]),
            " | ".join("%.2fx, %.2fx" % (float(d[(e, "equal_spp")]["material_over_mis_light_rgl"]),
                                         float(d[(e, "equal_time")]["material_over_mis_light_rgl"])) for e in est)))
    return out
