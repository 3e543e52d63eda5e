"""What scripts/converge_tables.py and scripts/light_tables.py share: reading the
study's CSVs, the (table, theta_o, phi_o) key, the number format, the error line."""

import csv
import math
import sys


def failer(prog):
    def fail(msg):
        print(prog + ": error: " + msg, file=sys.stderr)
        sys.exit(1)
    return fail


def read(path, needed, fail):
    try:
        with open(path, newline="") as f:
            rows = list(csv.DictReader(f))
    except OSError as e:
        fail("cannot read %s: %s" % (path, e))
    if not rows:
        fail("%s: no rows" % path)
    missing = [c for c in needed if c not in rows[0]]
    if missing:
        fail("%s: missing columns %s" % (path, ", ".join(missing)))
    return rows


def key(r):
    return (r["table"], round(float(r["theta_o"]), 6), round(float(r["phi_o"]), 6))


def fmt(x, digits=3):
    if x is None:
        return "-"
    if isinstance(x, str):
        return x
    if isinstance(x, int) and not isinstance(x, bool):
        return str(x)
    if not math.isfinite(x):
        return "inf" if x > 0 else "nan"
    if x != 0 and (abs(x) >= 1e5 or abs(x) < 1e-2):
        return "%.1e" % x
    if abs(x) >= 100:
        return "%.0f" % x
    return ("%." + str(digits) + "g") % x


def markdown_lines(rows, cols, cell):
    """cols: (heading, key, check); the Markdown table of cell(row, key, check), as lines."""
    out = ["| " + " | ".join(c[0] for c in cols) + " |", "|" + "---|" * len(cols)]
    for r in rows:
        out.append("| " + " | ".join(cell(r, n, ok) for _, n, ok in cols) + " |")
    return out


def print_table(rows, cols, cell, markdown):
    """A Markdown table (markdown_lines), else CSV of the raw values."""
    if markdown:
        print("\n".join(markdown_lines(rows, cols, cell)))
    else:
        w = csv.writer(sys.stdout)
        w.writerow([c[1] for c in cols])
        for r in rows:
            w.writerow([r[n] for _, n, _ in cols])


class Measures:
    """The estimators of one (table, direction, scene) against us_tab, from their
    convergence rows est[estimator][N]: us_tab's rel_rmse at n_target and ns_per_sample."""

    def __init__(self, est, n_target):
        self.est, self.n = est, n_target
        self.r_us = float(est["us_tab"][n_target]["rel_rmse"])
        self.ns_us = float(est["us_tab"][max(est["us_tab"])]["ns_per_sample"])

    def at_max(self, e, col):
        return float(self.est[e][max(self.est[e])][col]) if e in self.est else None

    def fewer(self, e):
        """How many times fewer samples than us_tab's n_target reach its error (1/sqrt(N))."""
        r = self.at_max(e, "rel_rmse")
        if r is None:
            return None
        n_e = max(self.est[e]) * (r / self.r_us) ** 2
        return self.n / n_e if n_e > 0 else math.inf

    def cost(self, e):
        ns = self.at_max(e, "ns_per_sample")
        return ns / self.ns_us if ns is not None else None

    def var(self, e):
        r = self.at_max(e, "rel_rmse")
        return r * r * max(self.est[e]) if r is not None else None
