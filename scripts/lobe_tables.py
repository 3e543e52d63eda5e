"""Doc tables of how the mixtures follow lobes (scripts/doc_tables.py): interpolation
between slices (bench/results/interpolation.csv) and the grids that resolve sharp lobes
(bench/results/rgl_resolve.csv)."""
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
    label = {"default": "default", "resolved": "resolved", "resolved_t2": "resolved, fit to 2 % L1"}
    out = ["| material | narrowest lobe, degrees (theta x across), at view | grid | table MiB | fit L1, median | mixture bytes | mixture / file's sampler, median (largest) | table CDF / file's |",
           "|---|---|---|---|---|---|---|---|"]
    for r in rows("rgl_resolve.csv"):
        measured = r["is_mixture_over_rgl_median"] != ""
        l1 = r.get("fit_l1_median", "")
        out.append("| %s | %s x %s at %s | %s: %s x %s x %s | %s | %s | %s | %s | %s |" % (
            r["material"], r["lobe_fwhm_theta_deg"], r["lobe_fwhm_across_deg"], r["lobe_at_theta_o_deg"],
            label.get(r["grid"], r["grid"]), r["theta_o"], r["theta_i"], r["phi_i"], r["table_mib"],
            "%.1f%%" % (100 * float(l1)) if l1 else "-", r["mixture_bytes"] or "-",
            "%s (%s)" % (r["is_mixture_over_rgl_median"], r["is_mixture_over_rgl_max"]) if measured else "not imported",
            "%s (%s)" % (r["cdf_table_over_rgl_median"], r["cdf_table_over_rgl_max"]) if measured else "-"))
    return out
