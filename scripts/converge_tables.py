#!/usr/bin/python3
"""The convergence study's measured table (docs/sampling.md, "Measured results"), from convergence CSVs.

For every (table, theta_o, phi_o, scene) of the CSVs, one row:
  K           components of the main slice serving omega_o (tail CSV)
  storage     table_bytes / mixture_bytes of the tail CSV: the float32 cells of the table
              slice (with its colour, where it has one) over the slice's share of the
              mixture file's datasets as stored (rgb_scale included)
              (arrays padded to the file's largest K, per-slice scalars included)
  mis fewer   how many times fewer samples mis_tab needs than us_tab's 1024 to reach
              us_tab's rel_rmse at N = 1024: 1024 / N_mis, N_mis = N_max (rel_rmse_mis at
              N_max / rel_rmse_us at 1024)^2 (the error falls as 1 / sqrt(N))
  mis time    the same in time: mis fewer x ns_us / ns_mis
  cost        ns_per_sample over us_tab's (one launch shape for every estimator), for
              is_tab, mis_tab and is_gmm: the cost of a mixture sample against a uniform one
  mis/cdf     mis_tab's variance over cdf_tab's (at N_max); cdf_tab is exact under
              constant lighting (zero variance but float rounding), so the ratio means
              something only where the lighting varies
  is fewer, is time   the same as mis fewer / mis time for is_tab, reported beside them
  is tail     the tail CSV's largest f / pdf over the integral for is_tab, and the share
              of the integral is_tab never samples (missed_is)

  scripts/converge_tables.py out/converge_polyester/polyester_convergence.csv \\
      out/converge_cotton/cotton_convergence.csv [--n 1024] [--markdown]
The tail CSV of X.csv is X_tail.csv unless --tail names them (same order).
"""

import argparse
import math
import os

from tables_common import Measures, failer, fmt, key, markdown_lines, print_table, read as read_csv

NEEDED = ["table", "theta_o", "phi_o", "scene", "estimator", "samples", "rel_rmse", "ns_per_sample"]


fail = failer("converge_tables")


def read(path, needed):
    return read_csv(path, needed, fail)


def measures(csvs, tails, n_target):
    out = []
    for path, tpath in zip(csvs, tails):
        rows = read(path, NEEDED)
        tail = {key(t): t for t in read(tpath, ["table", "theta_o", "phi_o", "k", "table_bytes", "mixture_bytes", "max_weight_is"])}
        groups = {}
        for r in rows:
            groups.setdefault(key(r) + (r["scene"],), {}).setdefault(r["estimator"], {})[int(r["samples"])] = r
        for g in sorted(groups, key=lambda g: (g[0], g[1], g[2], g[3])):
            est = groups[g]
            if "us_tab" not in est:
                continue
            if n_target not in est["us_tab"]:
                fail("%s: us_tab has no row at N = %d" % (path, n_target))

            m = Measures(est, n_target)
            fewer, cost, var = m.fewer, m.cost, m.var

            def time_ratio(e):
                f, c = fewer(e), cost(e)
                return f / c if f is not None and c else None

            t = tail.get(g[:3], {})
            k = int(t["k"]) if t else None
            v_mis, v_cdf = var("mis_tab"), var("cdf_tab")
            out.append(
                dict(
                    table=g[0], theta_o=g[1], phi_o=g[2], scene=g[3], k=k,
                    storage=int(t["table_bytes"]) / int(t["mixture_bytes"]) if t and int(t["mixture_bytes"]) else None,
                    mis_fewer=fewer("mis_tab"), mis_time=time_ratio("mis_tab"),
                    cost_is=cost("is_tab"), cost_mis=cost("mis_tab"), cost_isgmm=cost("is_gmm"),
                    ns_us=m.ns_us,
                    mis_cdf=v_mis / v_cdf if v_mis is not None and v_cdf else None,
                    is_fewer=fewer("is_tab"), is_time=time_ratio("is_tab"),
                    is_max_weight=float(t["max_weight_is"]) if t else None,
                    is_missed=float(t["missed_is"]) if t and "missed_is" in t else None,
                ))
    return out


def check(x, ok):
    return fmt(x)


COLS = [
    ("table", "table", None), ("theta_o (deg)", "theta_o", None), ("scene", "scene", None), ("K", "k", None),
    ("storage", "storage", lambda x: x >= 100), ("mis fewer N", "mis_fewer", lambda x: x >= 10),
    ("mis less time", "mis_time", lambda x: x >= 5), ("us_tab ns", "ns_us", None),
    ("cost is_tab", "cost_is", lambda x: x <= 2), ("cost mis_tab", "cost_mis", lambda x: x <= 2),
    ("cost is_gmm", "cost_isgmm", lambda x: x <= 2), ("mis/cdf var", "mis_cdf", None),
    ("is fewer N", "is_fewer", None), ("is less time", "is_time", None),
    ("is max f/pdf", "is_max_weight", None), ("is unsampled", "is_missed", None),
]


def cell(r, name, ok):
    x = r[name]
    if name == "theta_o":
        return "%.0f" % math.degrees(x)
    if name == "mis_cdf" and x is not None:
        return fmt(x)
    if ok is None:
        return fmt(x) if not isinstance(x, (int, str)) or isinstance(x, bool) else str(x)
    return check(x, ok)


def tails_of(csvs):
    return [os.path.splitext(p)[0] + "_tail.csv" for p in csvs]


def markdown(csvs, n_target=1024):
    """The Markdown table of the CSVs (their tails beside them), as lines (scripts/doc_tables.py)."""
    return markdown_lines(measures(csvs, tails_of(csvs), n_target), COLS, cell)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("csv", nargs="+", help="convergence CSV(s)")
    ap.add_argument("--tail", nargs="*", default=None, help="tail-risk CSV(s), one per CSV")
    ap.add_argument("--n", type=int, default=1024, help="us_tab's sample count to match (1024)")
    ap.add_argument("--markdown", action="store_true", help="a Markdown table (default: CSV)")
    a = ap.parse_args()
    tails = a.tail if a.tail else tails_of(a.csv)
    if len(tails) != len(a.csv):
        fail("--tail needs one file per CSV")
    print_table(measures(a.csv, tails, a.n), COLS, cell, a.markdown)


if __name__ == "__main__":
    main()
