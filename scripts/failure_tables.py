"""The failure map's tables (docs/studies/failure_map.md, docs/studies/stability_cases.md)
from bench/results/failure_map.csv, the CSV of `scripts/failure_map.py`
(scripts/doc_tables.py writes them between their markers)."""
import csv
import os

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CSV = os.path.join(ROOT, "bench", "results", "failure_map.csv")

# What each case is and what to prefer there: words, not measurements.
CASES = [
    ("spike", "spike: one hot cell", "Gaussians at the covariance floor (a quarter cell)",
     "`cdf_tab` (exact), else `mis_tab`"),
    ("phi_wrap", "lobe across phi = +-pi", "fitted like a lobe anywhere else", "`is_tab` or `mis_tab`"),
    ("theta_border", "lobe on the theta border (5 degrees inside +90)",
     "the Gaussians leak mass past the border, which the stand-in's amplitudes give back; is_tab stays unbiased "
     "(invalid samples count 0) but its largest weight in the tail CSV explodes", "`mis_tab`"),
    ("all_zero", "all-zero slice", "stored with scale 0; `converge` skips a zero "
     "direction with a warning, and stops with one error line if every direction is zero", "nothing to integrate"),
    ("constant", "constant slice", "`us_tab` is exact; every mixture estimator adds variance",
     "`us_tab` (or `cdf_tab`)"),
    ("dynamic_range", "weights 1e8 .. 1e-8 (16 decades)", "measured fine, but the tail CSV predicts is_tab's "
     "variance unbounded: the far floor lies where the mixture is all but 0", "`mis_tab`"),
    ("noise", "heavy noise (cotton, noise 0.5)", "the error is mostly the noise", "`mis_tab`"),
    ("k_gt_cells", "K above the non-zero cells (3 cells, K pinned 8)", "K lowered and reported; floor-width "
     "Gaussians, as the spike", "`cdf_tab`, else `mis_tab`"),
    ("line", "near-singular lobes (one theta row, a one-cell diagonal)", "covariances held at the floor; the "
     "stand-in (us_gmm, is_gmm) poor", "`mis_tab`"),
    ("heavy_tail", "heavy tails, 1/(1+(d/0.05)^2)^1.1", "the search adds broad components", "`is_tab` or `mis_tab`"),
    ("heavy_tail_k1", "heavy tails with K pinned 1", "is_tab's variance explodes", "`mis_tab`"),
    ("grazing", "lossless fiber at theta_o = +-88 degrees", "two grazing slices", "`mis_tab`"),
]


def read():
    with open(CSV, newline="") as f:
        return {r["case"]: r for r in csv.DictReader(f)}


def num(x, digits=2):
    """A measured value in the tables' short form: 2 significant digits, e-notation outside [0.01, 1e4)."""
    if x in ("", None):
        return "-"
    v = float(x)
    if v == 0:
        return "0"
    if abs(v) >= 1e4 or abs(v) < 1e-2:
        m, e = ("%.*e" % (digits - 1, v)).split("e")
        return "%se%d" % (m, int(e))
    t = "%.*g" % (digits, v)
    return t + ".0" if "." not in t and abs(v) < 10 else t


def pct(x):
    return "-" if x in ("", None) else "%.2g %%" % (100 * float(x))


def readme():
    by = read()
    out = ["| case | what happens (measured) | prefer |", "|---|---|---|"]
    for key, label, words, prefer in CASES:
        r = by.get(key)
        if r is None:
            out.append("| %s | not in the run | %s |" % (label, prefer))
            continue
        status = r["fit_status"].split(";")[0]
        if r["mse_ratio_is_tab"] == "":
            measured = "%s; reported `%s` in the fit report" % (words, status)
        else:
            measured = ("%s: K %s, l1_rel %s; MSE over us_tab's: is_tab %s, mis_tab %s, cdf_tab %s; predicted is_tab "
                        "%s; largest weight is_tab %s, mis_tab %s" % (
                            words, r["k"], "/".join(pct(v) for v in r["l1_rel"].split("/")), num(r["mse_ratio_is_tab"]),
                            num(r["mse_ratio_mis_tab"]), num(r["mse_ratio_cdf_tab"]), num(r["relvar_is_over_us"]),
                            num(r["max_weight_is"]), num(r["max_weight_mis"])))
            if status != "ok":
                measured += "; reported `%s`" % status
        out.append("| %s | %s | %s |" % (label, measured, prefer))
    return out


def stability():
    by = read()
    out = ["| case | fit status | K | l1_rel | us_gmm | is_tab | is_gmm | mis_tab | cdf_tab | pred. | w_is | w_mis | "
           "stand-in error | NaN/Inf | verdict |", "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for key, _, _, _ in CASES:
        r = by.get(key)
        if r is None:
            continue
        l1 = " / ".join(num(v) for v in r["l1_rel"].split("/"))
        out.append("| %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s |" % (
            key, r["fit_status"].split(";")[0], r["k"].replace("/", " / "), l1,
            *(num(r["mse_ratio_" + e]) for e in ("us_gmm", "is_tab", "is_gmm", "mis_tab", "cdf_tab")),
            num(r["relvar_is_over_us"]), num(r["max_weight_is"]), num(r["max_weight_mis"]), num(r["stand_in_error"]),
            r["nan_total"], r["verdict"]))
    return out
