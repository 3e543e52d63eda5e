#!/usr/bin/python3
"""`bsdfmix standin` on a small generated table (ctest standin_test):

    /usr/bin/python3 tests/standin_test.py --bsdfmix build/bsdfmix [--work DIR]

- the chosen stand-in meets its target as `bsdfmix compare` measures it, and is the
  candidate of fewest bytes that does (the median, and the p90 with --metric p90);
- a candidate of stride s holds the slices a fit with `theta_o_stride: s` writes, with its error;
- an impossible target exits 1 naming the closest candidate, and writes no stand-in;
- a byte budget is respected, and one below every candidate exits 1;
- a rerun reuses the fits; --extra-caps fits one cap past the first meeting the target;
- with fit.map auto on a hemisphere table, the first K cap's probe chooses the map of every cap;
- an RGL file is refused with the import command.
"""
import argparse
import csv
import os
import re
import shutil
import subprocess
import sys
import tempfile

import h5py
import numpy as np

CAPS, STRIDES = "2,4", "1,2,3"
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def run(bsdfmix, *args, expect=0):
    r = subprocess.run([bsdfmix, *args], capture_output=True, text=True)
    if r.returncode != expect:
        sys.exit("expected exit %d, got %d: %s\n%s%s" % (expect, r.returncode, " ".join(args), r.stdout, r.stderr))
    return r


def check(cond, what):
    if not cond:
        sys.exit("FAILED: " + what)
    print("ok:", what)


def candidates(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def compare_median(bsdfmix, mixture, table):
    out = run(bsdfmix, "compare", mixture, table, "--quiet").stdout
    m = re.search(r"every table slice.*?RGB error less its negative share median ([0-9.]+)%", out)
    check(m is not None, "compare prints the RGB median")
    return float(m.group(1))


def stand_in(bsdfmix, table, out, target, *extra, expect=0):
    return run(bsdfmix, "standin", table, "--target", str(target), "-o", out, "--k-caps", CAPS,
               "--strides", STRIDES, "--extra-caps", "0", "--quiet", *extra, expect=expect)


def same_mixtures(a, b):
    """"" when the two files hold the same slices (theta_o, phi_o, K) on the same table axes, with the
    same scales to float rounding: a slice's fit sums in an order its batch decides."""
    with h5py.File(a, "r") as fa, h5py.File(b, "r") as fb:
        ga, gb = fa["mixture"], fb["mixture"]
        for name in ("theta_o", "phi_o", "k", "table_theta_o", "table_phi_o"):
            if not np.array_equal(ga[name][()], gb[name][()]):
                return "%s differs" % name
        x, y = ga["scale"][()], gb["scale"][()]
        if np.max(np.abs(x - y) / np.abs(x)) > 1e-3:
            return "scale differs beyond rounding"
    return ""


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--bsdfmix", required=True)
    ap.add_argument("--work", default="")
    a = ap.parse_args()
    work = a.work or tempfile.mkdtemp(prefix="standin_test_")
    os.makedirs(work, exist_ok=True)
    b = a.bsdfmix
    table = os.path.join(work, "t.h5")
    if not os.path.exists(table):
        run(b, "generate", "fiber", "--preset", "cotton", "--theta-o", "7", "--theta-i", "16", "--phi-i", "32",
            "-o", table, "--quiet")

    # a target the candidates reach: the fewest bytes meeting it, confirmed by compare
    out = os.path.join(work, "s.h5")
    first = stand_in(b, table, out, 25, "--csv", os.path.join(work, "c.csv"))
    rows = candidates(os.path.join(work, "c.csv"))
    check(len(rows) == 3 and {r["k_max"] for r in rows} == {"2"},
          "K cap 2 meets 25%% at stride 1, so K cap 4 is not fitted (%d candidates)" % len(rows))
    check(not os.path.exists(os.path.join(work, "s.standin", "k4.h5")), "no fit at K cap 4")
    chosen = [r for r in rows if r["chosen"] == "1"]
    check(len(chosen) == 1, "one candidate is chosen")
    c = chosen[0]
    meeting = [r for r in rows if float(r["median"]) <= 0.25]
    check(int(c["bytes"]) == min(int(r["bytes"]) for r in meeting), "the chosen has the fewest bytes meeting 25%")
    measured = compare_median(b, out, table)
    check(measured <= 25 and abs(measured - 100 * float(c["median"])) < 0.01,
          "compare measures the stand-in at %.2f%% (the command said %.2f%%)" % (measured, 100 * float(c["median"])))
    check("chose stride" in first.stdout and "fewest bytes" in first.stdout, "the command says why")

    # the p90 metric: the fewest bytes whose p90 meets the target
    stand_in(b, table, os.path.join(work, "p90.h5"), 25, "--metric", "p90", "--csv", os.path.join(work, "p.csv"))
    prow = candidates(os.path.join(work, "p.csv"))
    pc = [r for r in prow if r["chosen"] == "1"][0]
    p_ok = [int(r["bytes"]) for r in prow if float(r["p90"]) <= 0.25]
    check(float(pc["p90"]) <= 0.25 and int(pc["bytes"]) == min(p_ok),
          "--metric p90 chooses the fewest bytes whose p90 meets 25%% (%s bytes, p90 %s)" % (pc["bytes"], pc["p90"]))

    # a candidate is the fit with theta_o_stride
    cfg = os.path.join(work, "stride.yaml")
    with open(cfg, "w") as f:
        f.write("table: %s\nfit:\n  output: %s/stride.h5\n  report: %s/stride_fit.csv\n"
                "  search_report: %s/stride_search.csv\n  k_max: 2\n  theta_o_stride: 3\n" % (table, work, work, work))
    run(b, "fit", cfg, "--quiet")
    subset = os.path.join(work, "s.standin", "s3_k2.h5")
    diff = same_mixtures(os.path.join(work, "stride.h5"), subset)
    check(diff == "", "stride 3's candidate holds the slices of a fit with theta_o_stride: 3 %s" % diff)
    strided = compare_median(b, os.path.join(work, "stride.h5"), table)
    cand = [r for r in rows if r["stride"] == "3"][0]
    check(abs(strided - 100 * float(cand["median"])) < 0.05,
          "and its error (%.2f%% against %.2f%%)" % (strided, 100 * float(cand["median"])))

    # a rerun reuses the fits; --extra-caps 1 fits one cap more than the first meeting, no further
    again = run(b, "standin", table, "--target", "25", "-o", out, "--k-caps", CAPS + ",8", "--strides", STRIDES,
                "--extra-caps", "1", "--csv", os.path.join(work, "e.csv"))
    check("K cap 2: reusing" in again.stderr and "K cap 4: fitting all" in again.stderr
          and "K cap 8" not in again.stderr, "a rerun reuses the fits, and fits one cap more")
    check(len(candidates(os.path.join(work, "e.csv"))) == 6, "the extra cap's candidates are measured")
    # stride 1 is always measured: without it in --strides, raising K still stops
    r = run(b, "standin", table, "--target", "25", "-o", out, "--k-caps", CAPS + ",8", "--strides", "2,3",
            "--extra-caps", "0", "--csv", os.path.join(work, "n.csv"))
    strides = sorted({x["stride"] for x in candidates(os.path.join(work, "n.csv"))})
    check(strides == ["1", "2", "3"] and "K cap 4" not in r.stderr, "stride 1 is measured when not named")

    # an impossible target: exit 1, the closest named, no stand-in written
    none_out = os.path.join(work, "none.h5")
    r = stand_in(b, table, none_out, 0.001, expect=1)
    check("no candidate meets median RGB error <= 0.001%" in r.stderr and "the closest: stride 1" in r.stderr,
          "an impossible target names the closest: " + r.stderr.strip())
    check(not os.path.exists(none_out), "no stand-in is written without a choice")

    # a byte budget: one that holds the choice keeps it; one just below it leaves only
    # candidates that miss the target: exit 1, the closest named within the budget
    bytes_chosen = int(c["bytes"])
    stand_in(b, table, os.path.join(work, "budget.h5"), 25, "--max-bytes", str(bytes_chosen), "--csv",
             os.path.join(work, "b.csv"))
    kept = [x for x in candidates(os.path.join(work, "b.csv")) if x["chosen"] == "1"][0]
    check(int(kept["bytes"]) == bytes_chosen, "a budget of %d bytes keeps the choice" % bytes_chosen)
    r = stand_in(b, table, os.path.join(work, "tight.h5"), 25, "--max-bytes", str(bytes_chosen - 1), expect=1)
    m = re.search(r"the closest: stride \d+ \(\d+ rows\), K cap \d+: (\d+) bytes", r.stderr)
    check("within %d bytes" % (bytes_chosen - 1) in r.stderr and m is not None and int(m.group(1)) < bytes_chosen,
          "a budget below the choice exits 1, naming the closest within it: " + r.stderr.strip())
    smallest = min(int(x["bytes"]) for x in rows)
    r = stand_in(b, table, os.path.join(work, "tiny.h5"), 99, "--max-bytes", str(smallest - 1), expect=1)
    check("within %d bytes" % (smallest - 1) in r.stderr, "a budget below every candidate exits 1")

    # fit.map auto on a hemisphere table: the first cap's probe chooses the map of every cap
    paper = os.path.join(work, "paper.h5")
    if not os.path.exists(paper):
        run(b, "import", "rgl", os.path.join(ROOT, "data", "rgl", "paper_white_rgb.bsdf"), "--theta-o", "12",
            "--theta-i", "16", "--phi-i", "32", "-o", paper, "--quiet")
    r = run(b, "standin", paper, "--target", "99", "-o", os.path.join(work, "paper_s.h5"), "--k-caps", "2,4",
            "--strides", "1", "--extra-caps", "1")
    check(r.stderr.count("choosing the map (fit.map auto)") == 1, "one probe for both caps")
    maps, settings = [], []
    for cap in ("k2", "k4"):
        with h5py.File(os.path.join(work, "paper_s.standin", cap + ".h5"), "r") as f:
            maps.append(f["mixture"].attrs["map"])
            settings.append(f["mixture"].attrs["fit_settings"])
    fitted = "equal_area" if maps[0] in (b"disk", "disk") else "theta_phi"
    check(maps[0] == maps[1] and '"map": "auto"' in str(settings[0]) and ('"map": "%s"' % fitted) in str(settings[1]),
          "both caps in the first cap's map (%s)" % maps[0])

    # an RGL file where a table belongs
    rgl = os.path.join(work, "x.bsdf")
    open(rgl, "wb").write(b"tensor_file")
    r = stand_in(b, rgl, out, 5, expect=1)
    check("bsdfmix import rgl" in r.stderr, "an RGL file is refused with the import command")
    if not a.work:
        shutil.rmtree(work)


if __name__ == "__main__":
    main()
