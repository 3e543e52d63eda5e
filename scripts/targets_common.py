"""What scripts/converge_targets.py and scripts/light_targets.py share: reading the
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


def print_table(rows, cols, cell, markdown):
    """cols: (heading, key, check); a Markdown table of cell(row, key, check), else CSV of the raw values."""
    if markdown:
        print("| " + " | ".join(c[0] for c in cols) + " |")
        print("|" + "---|" * len(cols))
        for r in rows:
            print("| " + " | ".join(cell(r, n, ok) for _, n, ok in cols) + " |")
    else:
        w = csv.writer(sys.stdout)
        w.writerow([c[1] for c in cols])
        for r in rows:
            w.writerow([r[n] for _, n, _ in cols])
