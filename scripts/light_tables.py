#!/usr/bin/python3
"""The measured table of sampling with the lighting (docs/studies/sampling_lighting.md, "The table").

For every (table, theta_o, phi_o, scene) of the convergence CSVs, one row:
  K, K light, K prod   the BSDF mixture's components (tail CSV), the lighting mixture's and
                       the product's after pruning (light tail CSV), and the share of the
                       product's mass the pruned pairs keep
  X fewer N            how many times fewer samples estimator X needs than us_tab's N (1024)
                       to reach us_tab's rel_rmse there: N / N_X, N_X = N_max (rel_rmse_X at
                       N_max / rel_rmse_us at N)^2 (the error falls as 1 / sqrt(N)); for
                       mis_product, mis_light_cdf (light + table CDF: the renderer baseline)
                       and mis_light_gmm (light + the BSDF mixture)
  vs baseline          mis_light_cdf's variance over mis_product's at N_max: how many times
                       fewer samples mis_product needs than the baseline
  less time            mis_product fewer N x ns_us / ns_mis_product
  cost                 ns_per_sample over us_tab's (one launch shape for every estimator)
  max f/pdf            the light tail CSV's largest f/pdf over the integral of mis_product
  fit s, break-even    the lighting mixture's fit time, and after how many integrals (shading
                       points) at us_tab's N = 1024 error the time mis_product saves over
                       mis_light_cdf pays for it

  scripts/light_tables.py out/converge_light_polyester/polyester_convergence.csv ... [--n 1024] [--markdown]
The tail CSVs of X.csv are X_tail.csv and X_light_tail.csv.
"""

import argparse
import math
import os

from tables_common import Measures, failer, fmt, key, markdown_lines, print_table, read as read_csv

NEEDED = ["table", "theta_o", "phi_o", "scene", "estimator", "samples", "rel_rmse", "ns_per_sample"]


fail = failer("light_tables")


def read(path, needed):
    return read_csv(path, needed, fail)


def measures(csvs, n_target):
    out = []
    for path in csvs:
        stem = os.path.splitext(path)[0]
        rows = read(path, NEEDED)
        tail = {key(t): t for t in read(stem + "_tail.csv", ["table", "theta_o", "phi_o", "k"])}
        light = {}
        for t in read(stem + "_light_tail.csv", ["table", "theta_o", "phi_o", "scene", "estimator", "max_weight",
                                                 "k_light", "light_fit_seconds", "k_product", "product_kept"]):
            light[key(t) + (t["scene"], t["estimator"])] = t
        groups = {}
        for r in rows:
            groups.setdefault(key(r) + (r["scene"],), {}).setdefault(r["estimator"], {})[int(r["samples"])] = r
        for g in sorted(groups):
            est = groups[g]
            if "us_tab" not in est or "mis_product" not in est:
                continue
            if n_target not in est["us_tab"]:
                fail("%s: us_tab has no row at N = %d" % (path, n_target))

            m = Measures(est, n_target)
            at_max, fewer, cost, var = m.at_max, m.fewer, m.cost, m.var

            lt = light.get(g + ("mis_product",), {})
            f_mp, f_mlc = fewer("mis_product"), fewer("mis_light_cdf")
            v_mp, v_mlc = var("mis_product"), var("mis_light_cdf")
            ns_mp, ns_mlc = at_max("mis_product", "ns_per_sample"), at_max("mis_light_cdf", "ns_per_sample")
            fit_s = float(lt["light_fit_seconds"]) if lt and lt["light_fit_seconds"] else None
            break_even = None
            if fit_s is not None and f_mp and f_mlc and ns_mlc:
                saved = n_target / f_mlc * ns_mlc - n_target / f_mp * ns_mp  # ns per integral
                break_even = fit_s * 1e9 / saved if saved > 0 else math.inf
            out.append(dict(
                table=g[0], theta_o=g[1], phi_o=g[2], scene=g[3],
                k=int(tail[g[:3]]["k"]) if g[:3] in tail else None,
                k_light=int(lt["k_light"]) if lt else None,
                k_product=int(lt["k_product"]) if lt else None,
                kept=float(lt["product_kept"]) if lt else None,
                mp_fewer=f_mp, mp_vs_base=v_mlc / v_mp if v_mp and v_mlc is not None else None,
                mp_time=f_mp / cost("mis_product") if f_mp is not None else None,
                mlc_fewer=f_mlc, mlg_fewer=fewer("mis_light_gmm"), mis_fewer=fewer("mis_tab"),
                cost_mp=cost("mis_product"), cost_mlc=cost("mis_light_cdf"), cost_mlg=cost("mis_light_gmm"),
                max_weight=float(lt["max_weight"]) if lt else None,
                fit_s=fit_s, break_even=break_even,
            ))
    return out


COLS = [
    ("table", "table", None), ("theta_o (deg)", "theta_o", None), ("scene", "scene", None), ("K", "k", None),
    ("K light", "k_light", None), ("K prod", "k_product", None), ("kept", "kept", None),
    ("mis_product fewer N", "mp_fewer", lambda x: x >= 20), ("vs baseline", "mp_vs_base", lambda x: x >= 2.5),
    ("less time", "mp_time", None), ("mis_light_cdf fewer N", "mlc_fewer", None),
    ("mis_light_gmm fewer N", "mlg_fewer", None), ("mis_tab fewer N", "mis_fewer", None),
    ("cost mis_product", "cost_mp", lambda x: x <= 3), ("cost mis_light_cdf", "cost_mlc", None),
    ("cost mis_light_gmm", "cost_mlg", None), ("max f/pdf", "max_weight", lambda x: x <= 10),
    ("fit s", "fit_s", None), ("break-even", "break_even", None),
]


def cell(r, name, ok):
    x = r[name]
    if name == "theta_o":
        return "%.0f" % math.degrees(x)
    return fmt(x)


def markdown(csvs, n_target=1024):
    """The Markdown table of the CSVs, as lines (scripts/doc_tables.py)."""
    return markdown_lines(measures(csvs, n_target), COLS, cell)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("csv", nargs="+", help="convergence CSV(s) with the lighting estimators")
    ap.add_argument("--n", type=int, default=1024, help="us_tab's sample count to match (1024)")
    ap.add_argument("--markdown", action="store_true", help="a Markdown table (default: CSV)")
    a = ap.parse_args()
    rows = measures(a.csv, a.n)
    if not rows:
        fail("no (direction, scene) with both us_tab and mis_product in " + ", ".join(a.csv))
    print_table(rows, COLS, cell, a.markdown)


if __name__ == "__main__":
    main()
