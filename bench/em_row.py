"""One `bsdfmix bench em` run of a build, as the studies that compare builds read it
(bench/em_speed.py, em_builds.py, house_speed.py).

`bench em` times the marginal cost of an iteration: fits of I and 1 iterations, their
difference over I - 1, so that a batch's setup (buffers, the upload of the weights) is not
counted (its profile line then ends "batch setup (not in s/iteration) ..."). Builds before
that timed the setup into the iterations. For such a build the run is repeated at twice the
iterations and the marginal cost taken the same way, so that two builds compare alike.
"""
import csv
import subprocess
import sys

NEW_TIMING = "batch setup (not in s/iteration)"


def _run(exe, k, path, iterations, extra):
    cmd = [exe, "bench", "em", "--k", str(k), "--iterations", str(iterations), "--repeat", "1", "--no-peers",
           "--no-reference", "--csv", path, "-q"] + list(extra)
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit("bench em failed: %s\n%s%s" % (" ".join(cmd), r.stdout[-2000:], r.stderr[-2000:]))
    with open(path) as f:
        row = next((x for x in csv.DictReader(f) if x["impl"].startswith("bsdfmix")), None)
    if row is None:
        sys.exit("bench em: no bsdfmix row in " + path)
    return row, NEW_TIMING in r.stdout


def bench_em(exe, k, path, extra=(), iterations=20):
    """The bsdfmix row (a dict of the CSV's columns) of `exe bench em --k k`, one round, no peers,
    no reference; seconds_per_iteration is the marginal cost of an iteration whatever the build,
    and pc_per_s, gflops and pct_of_fma_peak follow it."""
    row, marginal = _run(exe, k, path, iterations, extra)
    if marginal:
        return row
    row2, _ = _run(exe, k, path, 2 * iterations, extra)
    s1, s2 = float(row["seconds_per_iteration"]), float(row2["seconds_per_iteration"])
    spi = (2 * iterations * s2 - iterations * s1) / iterations
    scale = s2 / spi if spi > 0 else float("nan")
    out = dict(row2)
    out["seconds_per_iteration"] = "%.6g" % spi
    out["iterations"] = str(iterations)
    for key in ("pc_per_s", "gflops", "pct_of_fma_peak"):
        if out.get(key):
            out[key] = "%.6g" % (float(out[key]) * scale)
    return out
