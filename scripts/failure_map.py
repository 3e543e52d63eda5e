#!/usr/bin/python3
"""The failure map: runs the fit and the estimators over tables built to break them.

For every case in configs/stress/ (one config per case) this script
  1. builds the case's table (out/failure_map/<case>/table.h5; synthetic cases with
     h5py following the table format of docs/formats.md, fiber cases with `bsdfmix generate`),
  2. runs `bsdfmix fit` and `bsdfmix converge` on it through the binary,
  3. reads every output (mixture file, fit report, search CSV, convergence and tail
     CSVs) and records the relative L1 error, the chosen K, the failure status, the
     MSE of each estimator at a fixed N relative to us_tab, the bias of the table
     estimators in standard errors, and the count of NaN/Inf values in every output,
and writes out/failure_map/failure_map.csv and the chart failure_map.png/.svg.

    scripts/failure_map.py [--bsdfmix build/bsdfmix] [--cases spike,constant] [--out out/failure_map]

Run from the repository root. Exit status 0 when every case passes the stability
checks (finite outputs, failures reported, table estimators unbiased), 1 otherwise.
"""
import argparse
import csv
import json
import math
import os
import subprocess
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bsdfmix_import  # noqa: E402

bsdfmix = bsdfmix_import.load()

CASES = ["spike", "phi_wrap", "theta_border", "all_zero", "constant", "dynamic_range", "noise",
         "k_gt_cells", "line", "heavy_tail", "heavy_tail_k1", "grazing"]
ESTIMATORS = ["us_tab", "us_gmm", "is_tab", "is_gmm", "mis_tab", "cdf_tab"]
TABLE_ESTIMATORS = ["us_tab", "is_tab", "mis_tab", "cdf_tab"]
N_THETA_I, N_PHI_I = 45, 90
N_FIXED = 1024          # the N at which variances are compared
BIAS_Z = 4.5            # |mean - reference| above this many standard errors: biased
REL_FLOOR = 1e-5        # ... and above this relative error (float rounding of the kernels' sums)


# ---- tables ----------------------------------------------------------------------------

def centers(lo, hi, n):
    step = (hi - lo) / n
    return lo + step * (np.arange(n) + 0.5)


def grid():
    th = centers(-math.pi / 2, math.pi / 2, N_THETA_I)
    ph = centers(-math.pi, math.pi, N_PHI_I)
    T, P = np.meshgrid(th, ph, indexing="ij")
    return th, ph, T, P


def unit(theta, phi):
    """Fiber frame direction: sin(theta) along the axis, phi the azimuth around it."""
    return np.stack([np.sin(theta), np.cos(theta) * np.cos(phi), np.cos(theta) * np.sin(phi)], axis=-1)


def angle_to(T, P, theta0, phi0):
    d = unit(T, P) @ unit(np.array(theta0), np.array(phi0))
    return np.arccos(np.clip(d, -1.0, 1.0))


def wrapped(x):
    return (x + math.pi) % (2 * math.pi) - math.pi


def synthetic_slice(case):
    """f over (theta_i, phi_i) for one slice (theta_o = 0), and a description."""
    th, ph, T, P = grid()
    f = np.zeros_like(T)
    if case == "spike":
        f[N_THETA_I // 2 + 5, N_PHI_I // 2 + 7] = 1e4
        src = "one hot cell, f = 1e4"
    elif case == "phi_wrap":
        s = 0.15
        f = 10.0 * np.exp(-0.5 * ((T - 0.2) ** 2 + wrapped(P - math.pi) ** 2) / s ** 2)
        src = "gaussian lobe at (0.2, pi), sigma 0.15"
    elif case == "theta_border":
        s = 0.12
        f = 10.0 * np.exp(-0.5 * ((T - (math.pi / 2 - 0.0873)) ** 2 + wrapped(P - 0.5) ** 2) / s ** 2)
        src = "gaussian lobe at (pi/2 - 5 deg, 0.5), sigma 0.12"
    elif case == "all_zero":
        src = "zero"
    elif case == "constant":
        f[:] = 1.0 / (4 * math.pi)
        src = "constant 1/(4 pi)"
    elif case == "dynamic_range":
        d = angle_to(T, P, 0.3, -1.0)
        f = 10.0 ** (8.0 - 16.0 * d / d.max())
        src = "log10 f = 8 - 16 d / d_max"
    elif case == "k_gt_cells":
        f[10, 20] = 1.0
        f[22, 45] = 2.0
        f[35, 70] = 0.5
        src = "3 non-zero cells"
    elif case == "line":
        row = N_THETA_I // 2 + 6
        f[row, :] = 5.0 * np.exp(-0.5 * (wrapped(P[row] - 1.0) / 0.8) ** 2)
        dth = th[1] - th[0]
        diag = np.abs(T - (0.35 * wrapped(P + 1.5) - 0.6)) < dth / 2
        diag &= np.abs(wrapped(P + 1.5)) < 1.2
        f[diag] += 3.0
        src = "one theta row (ring) + one-cell-wide diagonal line"
    elif case in ("heavy_tail", "heavy_tail_k1"):
        d = angle_to(T, P, 0.25, 0.8)
        f = 1.0 / (1.0 + (d / 0.05) ** 2) ** 1.1
        src = "1/(1+(d/0.05)^2)^1.1"
    else:
        raise ValueError(case)
    return th, ph, f.astype(np.float32), src


def write_table(path, case):
    import h5py
    th, ph, f, src = synthetic_slice(case)
    os.makedirs(os.path.dirname(path), exist_ok=True)
    tmp = path + ".tmp"
    with h5py.File(tmp, "w") as h:
        g = h.create_group("table")
        g.create_dataset("values", data=f.reshape(1, 1, N_THETA_I, N_PHI_I), dtype="float32",
                         chunks=(1, 1, N_THETA_I, N_PHI_I))
        g.create_dataset("theta_o", data=np.array([0.0]), dtype="float64")
        g.create_dataset("phi_o", data=np.array([0.0]), dtype="float64")
        g.create_dataset("theta_i", data=th, dtype="float64")
        g.create_dataset("phi_i", data=ph, dtype="float64")
        g.attrs["domain"] = "fiber"
        g.attrs["symmetry"] = "azimuthal"
        g.attrs["source"] = json.dumps({"model": "failure_map", "case": case, "f": src})
    os.replace(tmp, path)


def build_table(case, path, binary, log):
    if case == "noise":
        cmd = [binary, "generate", "fiber", "--preset", "cotton", "--noise", "0.5", "--theta-o", "1",
               "--theta-i", str(N_THETA_I), "--phi-i", str(N_PHI_I), "-q", "-o", path]
    elif case == "grazing":
        cmd = [binary, "generate", "fiber", "--preset", "lossless", "--theta-o", "45",
               "--theta-i", str(N_THETA_I), "--phi-i", str(N_PHI_I), "-q", "-o", path]
    else:
        write_table(path, case)
        return None
    os.makedirs(os.path.dirname(path), exist_ok=True)
    r = subprocess.run(cmd, capture_output=True, text=True)
    log.write("$ " + " ".join(cmd) + "\n" + r.stdout + r.stderr)
    if r.returncode != 0:
        return "generate failed: " + last_line(r.stderr)
    return None


# ---- reading outputs --------------------------------------------------------------------

def last_line(text):
    lines = [l for l in text.strip().splitlines() if l.strip()]
    return lines[-1] if lines else ""


def simple_yaml(path):
    """The few keys this script needs from a stress config (table, fit.*, converge.*)."""
    out, section = {}, None
    for raw in open(path):
        line = raw.split("#", 1)[0].rstrip()
        if not line.strip():
            continue
        key, _, val = line.strip().partition(":")
        val = val.strip()
        if not raw.startswith(" "):
            section = key if not val else None
            if val:
                out[key] = val
        elif section:
            out[section + "." + key] = val
    return out


def nonfinite_in_csv(path):
    """NaN/Inf fields in a CSV (any spelling), and the parsed rows."""
    if not os.path.exists(path):
        return 0, []
    bad, rows = 0, []
    with open(path, newline="") as fh:
        for row in csv.DictReader(fh):
            rows.append(row)
            for v in row.values():
                if v is None:
                    continue
                t = v.strip().lower()
                if t in ("nan", "-nan", "+nan", "inf", "-inf", "+inf", "infinity", "-infinity"):
                    bad += 1
                else:
                    try:
                        if not math.isfinite(float(t)):
                            bad += 1
                    except ValueError:
                        pass
    return bad, rows


def nonfinite_in_mixture(path):
    import h5py
    if not os.path.exists(path):
        return 0, None
    bad, m = 0, {}
    with h5py.File(path, "r") as h:
        g = h["mixture"]
        for name in g:
            a = np.asarray(g[name][()])
            m[name] = a
            if a.dtype.kind == "f":
                bad += int(np.count_nonzero(~np.isfinite(a)))
    return bad, m


def mixture_problems(m, path):
    """Parameter sanity beyond finiteness: weights sum to 1, covariances positive definite;
    and the file as a renderer gets it: bsdfmix's reader accepts it and the header's stand-in
    (through the Python module) is finite over the domain at every fitted slice."""
    probs = []
    if m is None:
        return probs
    try:
        mix = bsdfmix.load_mixture(path)
        lo = -math.pi / 2 if mix.domain == bsdfmix.Domain.fiber else 0.0
        T, P = np.meshgrid(centers(lo, math.pi / 2, N_THETA_I), centers(-math.pi, math.pi, N_PHI_I), indexing="ij")
        for s, sl in enumerate(mix.slices):
            f = mix.eval_f(sl.theta_o, sl.phi_o, T, P)
            if not np.isfinite(f).all():
                probs.append("slice %d: the stand-in is not finite at %d cells" % (s, np.count_nonzero(~np.isfinite(f))))
    except (bsdfmix.Error, ValueError, IndexError) as e:
        probs.append("the reader or the header rejects the file: %s" % e)
    for s, k in enumerate(m["k"]):
        w = m["weights"][s, :k].astype(float)
        if abs(w.sum() - 1) > 1e-4 or (w < 0).any():
            probs.append("slice %d: weights sum %.6g" % (s, w.sum()))
        c = m["covariances"][s, :k].astype(float)
        det = c[:, 0] * c[:, 2] - c[:, 1] ** 2
        if (c[:, 0] <= 0).any() or (c[:, 2] <= 0).any() or (det <= 0).any():
            probs.append("slice %d: covariance not positive definite" % s)
    return probs


# ---- one case ---------------------------------------------------------------------------

def run_case(case, args, log):
    cfg_path = os.path.join(args.configs, case + ".yaml")
    cfg = simple_yaml(cfg_path)
    table = cfg["table"]
    res = {"case": case, "config": cfg_path, "table": table}
    os.makedirs(os.path.dirname(table), exist_ok=True)
    t0 = time.time()
    err = build_table(case, table, args.bsdfmix, log)
    if err:
        res.update(fit_status=err, converge_status="not run")
        return res
    dev = ["--device", args.device] if args.device else []

    for key in ("fit.output", "fit.report", "fit.search_report", "converge.csv"):
        if os.path.exists(cfg[key]):
            os.remove(cfg[key])
    r = subprocess.run([args.bsdfmix, "fit", cfg_path] + dev, capture_output=True, text=True)
    log.write("$ bsdfmix fit %s\n%s%s[exit %d]\n" % (cfg_path, r.stdout, r.stderr, r.returncode))
    res["fit_exit"] = r.returncode
    res["fit_error"] = last_line(r.stderr) if r.returncode else ""

    nan_mix, m = nonfinite_in_mixture(cfg["fit.output"])
    nan_rep, rep = nonfinite_in_csv(cfg["fit.report"])
    nan_search, _ = nonfinite_in_csv(cfg["fit.search_report"])
    res["nan_mixture"], res["nan_report"], res["nan_search"] = nan_mix, nan_rep, nan_search
    res["mixture_problems"] = "; ".join(mixture_problems(m, cfg["fit.output"]))
    if rep:
        res["l1_rel"] = max(float(x["l1_rel"]) for x in rep)
        res["k"] = "/".join(x["k"] for x in rep)
        res["k_max_chosen"] = max(int(x["k"]) for x in rep)
        res["iterations"] = "/".join(x["iterations"] for x in rep)
        statuses = []
        for x in rep:
            st = (x.get("status") or "").strip()
            if not st:  # report without a status column: the sweep's fallback has loglik 0, 0 iterations
                st = "fallback (moment Gaussian)" if (x["iterations"] == "0" and float(x["loglik"]) == 0) else "ok"
            statuses.append(st)
        res["fit_status"] = "ok" if all(s == "ok" for s in statuses) else "; ".join(sorted(set(s for s in statuses if s != "ok")))
    else:
        res["fit_status"] = "error: " + res["fit_error"] if r.returncode else "no report"

    conv_tail = os.path.splitext(cfg["converge.csv"])[0] + "_tail.csv"
    if os.path.exists(conv_tail):
        os.remove(conv_tail)
    if r.returncode == 0:
        r2 = subprocess.run([args.bsdfmix, "converge", cfg_path] + dev, capture_output=True, text=True)
        log.write("$ bsdfmix converge %s\n%s%s[exit %d]\n" % (cfg_path, r2.stdout, r2.stderr, r2.returncode))
        res["converge_exit"] = r2.returncode
        res["converge_status"] = "ok" if r2.returncode == 0 else "error: " + last_line(r2.stderr)
        res["converge_nan_in_log"] = sum(1 for l in (r2.stderr + r2.stdout).lower().split() if l.strip(",;:") in ("nan", "-nan", "inf", "-inf"))
    else:
        res["converge_status"] = "not run (fit failed)"
    nan_conv, conv = nonfinite_in_csv(cfg["converge.csv"])
    nan_tail, tail = nonfinite_in_csv(conv_tail)
    res["nan_convergence"], res["nan_tail"] = nan_conv, nan_tail
    res["nan_total"] = nan_mix + nan_rep + nan_search + nan_conv + nan_tail
    if tail:
        res["relvar_is_over_us"] = max(float(t["relvar_is"]) / float(t["relvar_us"]) for t in tail
                                       if float(t["relvar_us"]) > 0) if any(float(t["relvar_us"]) > 0 for t in tail) else float("nan")
        res["max_weight_is"] = max(float(t["max_weight_is"]) for t in tail)
        res["max_weight_mis"] = max(float(t["max_weight_mis"]) for t in tail)
        res["stand_in_error"] = max(abs(float(t["stand_in_error"])) for t in tail)

    # Estimators: MSE at N_FIXED relative to us_tab (worst direction), bias at the largest N.
    biased = []
    if conv:
        dirs = sorted(set(x["theta_o"] for x in conv))
        nmax = max(int(x["samples"]) for x in conv)
        for e in ESTIMATORS:
            ratios, zs, rels = [], [], []
            for d in dirs:
                def row(est, n):
                    for x in conv:
                        if x["theta_o"] == d and x["estimator"] == est and int(x["samples"]) == n:
                            return x
                    return None
                a, u = row(e, N_FIXED), row("us_tab", N_FIXED)
                if a and u and float(u["rmse"]) > 0:
                    ratios.append((float(a["rmse"]) / float(u["rmse"])) ** 2)
                elif a and u:
                    ratios.append(float("inf") if float(a["rmse"]) > 0 else 1.0)
                last = row(e, nmax)
                if last:
                    mean, ref, rmse, runs = (float(last[k]) for k in ("mean", "reference", "rmse", "runs"))
                    var = max(rmse * rmse - (mean - ref) ** 2, 0.0)
                    se = math.sqrt(var / runs)
                    rel = (mean - ref) / ref if ref else float("inf")
                    rels.append(rel)
                    if se > 0:
                        zs.append((mean - ref) / se)
                    else:  # zero spread (cdf_tab under constant light): exact up to float rounding
                        zs.append(0.0 if abs(rel) < REL_FLOOR else float("inf"))
            res["mse_ratio_" + e] = max(ratios) if ratios else float("nan")
            res["bias_z_" + e] = max(zs, key=abs) if zs else float("nan")
            res["bias_rel_" + e] = max(rels, key=abs) if rels else float("nan")
            # Biased: off by more than BIAS_Z standard errors and by more than float rounding
            # (the kernels sum in float: a zero-variance estimator is exact only to ~1e-7).
            if e in TABLE_ESTIMATORS and any(not (math.isfinite(z) and math.isfinite(rl)) or
                                             (abs(z) > BIAS_Z and abs(rl) > REL_FLOOR) for z, rl in zip(zs, rels)):
                biased.append(e)
    res["biased_table_estimators"] = " ".join(biased)
    res["seconds"] = round(time.time() - t0, 1)

    # The verdict of the stability contract.
    problems = []
    if res["nan_total"]:
        problems.append("%d NaN/Inf in outputs" % res["nan_total"])
    if res.get("mixture_problems"):
        problems.append(res["mixture_problems"])
    if res.get("fit_exit", 0) != 0:
        problems.append("fit exit %d: %s" % (res["fit_exit"], res["fit_error"]))
    if biased:
        problems.append("biased: " + " ".join(biased))
    conv_ok = res.get("converge_status") == "ok"
    zero_case = res.get("converge_status", "").find("zero") >= 0
    if not conv_ok and not zero_case:
        problems.append("converge: " + res.get("converge_status", ""))
    res["verdict"] = "pass" if not problems else "FAIL: " + "; ".join(problems)
    return res


# ---- chart ------------------------------------------------------------------------------

def status_color(st):
    if st == "ok":
        return "tab:blue"
    if st.startswith("reduced"):
        return "tab:orange"
    return "tab:red"


def chart(results, out_dir):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = [r["case"] for r in results]
    x = np.arange(len(names))
    fig, axes = plt.subplots(5, 1, figsize=(13, 17), gridspec_kw={"height_ratios": [1, 0.7, 1.6, 0.6, 1.0]})
    fig.suptitle("bsdfmix failure map: fits and estimators on tables built to break them\n"
                 "(45 x 90 cells per slice, fiber domain; estimators at N = %d, 64 runs, constant lighting)" % N_FIXED)
    colors = [status_color(r.get("fit_status", "ok")) for r in results]

    ax = axes[0]
    l1 = np.array([r.get("l1_rel", np.nan) for r in results], dtype=float)
    ax.bar(x, np.where(np.isfinite(l1), np.maximum(l1, 1e-6), 0), color=colors)
    for xi, v in zip(x, l1):
        ax.text(xi, min(max(v, 1.2e-4), 10) if np.isfinite(v) else 1.2e-4, "%.3g" % v if np.isfinite(v) else "n/a",
                ha="center", va="bottom", fontsize=8)
    ax.set_yscale("log")
    ax.set_ylim(1e-4, 30)
    ax.set_ylabel("fit error\n(relative L1)")
    ax.axhline(0.05, color="gray", lw=0.8, ls="--")
    ax.text(len(names) - 0.5, 0.055, "5%", color="gray", fontsize=8, ha="right")
    ax.set_title("bar color = fit status: blue ok, orange K reduced, red zero slice or failed (see the table below)",
                 fontsize=9, loc="left")

    ax = axes[1]
    ks = [r.get("k_max_chosen", 0) for r in results]
    ax.bar(x, ks, color=colors)
    for xi, k, r in zip(x, ks, results):
        ax.text(xi, k, r.get("k", "-"), ha="center", va="bottom", fontsize=8)
    ax.set_ylabel("chosen K")
    ax.set_ylim(0, max(ks + [1]) * 1.35 + 1)
    for a in axes[:2]:
        a.set_xticks(x)
        a.set_xticklabels(names, fontsize=8)

    ax = axes[2]
    markers = {"us_tab": "o", "us_gmm": "s", "is_tab": "^", "is_gmm": "v", "mis_tab": "D", "cdf_tab": "*"}
    off = np.linspace(-0.32, 0.32, len(ESTIMATORS))
    top = 1e10
    for j, e in enumerate(ESTIMATORS):
        ys = np.array([r.get("mse_ratio_" + e, np.nan) for r in results], dtype=float)
        ax.scatter(x + off[j], np.clip(ys, 1e-13, top), marker=markers[e], s=40, label=e + " (measured)", zorder=3)
        for xi, y, r in zip(x + off[j], ys, results):
            if e in r.get("biased_table_estimators", "").split():
                ax.scatter([xi], [min(max(y, 1e-13), top)], s=160, facecolors="none", edgecolors="red", zorder=4)
            if np.isfinite(y) and y > top:
                ax.annotate("%.0e" % y, (xi, top), fontsize=6, ha="center", va="bottom", rotation=90)
    pred = np.array([r.get("relvar_is_over_us", np.nan) for r in results], dtype=float)
    ax.scatter(x + off[2], np.clip(pred, 1e-13, top), marker="x", s=60, color="k", zorder=5,
               label="is_tab predicted (tail CSV)")
    for xi, y in zip(x + off[2], pred):
        if np.isfinite(y) and y > 10:
            ax.annotate("predicted %.0e" % y, (xi, min(y, top / 30)), fontsize=7, ha="left", va="top", color="k")
    ax.axhline(1, color="gray", lw=0.8)
    ax.set_yscale("log")
    ax.set_ylim(3e-14, 3e12)
    ax.set_ylabel("MSE / MSE(us_tab)\n(below 1: better than uniform)")
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.005, 1.0))
    ax.set_title("gmm estimators: MSE includes the stand-in's bias; red ring: table estimator biased; "
                 "constant slice: us_tab is exact, so every ratio is huge", fontsize=9, loc="left")
    ax.set_xticks(x)
    ax.set_xticklabels(names, fontsize=8)

    ax = axes[3]
    parts = [("mixture", "nan_mixture"), ("fit report", "nan_report"), ("search", "nan_search"),
             ("convergence", "nan_convergence"), ("tail", "nan_tail")]
    bottom = np.zeros(len(names))
    for lbl, key in parts:
        v = np.array([r.get(key, 0) for r in results], dtype=float)
        ax.bar(x, v, bottom=bottom, label=lbl)
        bottom += v
    for xi, tot in zip(x, bottom):
        ax.text(xi, tot, "%d" % tot, ha="center", va="bottom", fontsize=9)
    ax.set_ylabel("NaN/Inf values\nin the outputs")
    ax.set_ylim(0, max(bottom.max(), 1) * 2.5)
    ax.legend(ncol=5, fontsize=8, loc="upper right")
    ax.set_xticks(x)
    ax.set_xticklabels(names, rotation=20, ha="right")

    ax = axes[4]
    ax.axis("off")
    rows = []
    for r in results:
        conv = r.get("converge_status", "?").replace("bsdfmix: error: ", "").replace(r.get("table", "") + ": ", "")
        rows.append([r["case"], r.get("fit_status", "?")[:70], conv[:70],
                     "pass" if r["verdict"] == "pass" else "FAIL"])
    t = ax.table(cellText=rows, colLabels=["case", "fit status (report)", "converge", "stability"],
                 loc="center", cellLoc="left", colWidths=[0.13, 0.45, 0.34, 0.08])
    t.auto_set_font_size(False)
    t.set_fontsize(7.5)
    t.scale(1, 1.25)
    for i, r in enumerate(results):
        if r["verdict"] != "pass":
            t[i + 1, 3].set_text_props(color="red")
    fig.tight_layout(rect=(0, 0, 1, 0.97))
    for ext in ("png", "svg"):
        fig.savefig(os.path.join(out_dir, "failure_map." + ext), dpi=110)
    plt.close(fig)


def fmt(v):
    if isinstance(v, float):
        if math.isnan(v):
            return ""
        return "%.4g" % v
    return str(v)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--bsdfmix", default="build/bsdfmix", help="the bsdfmix binary (default build/bsdfmix)")
    ap.add_argument("--configs", default="configs/stress", help="the case configs (default configs/stress)")
    ap.add_argument("--out", default="out/failure_map", help="where the CSV, chart and log go")
    ap.add_argument("--cases", default=",".join(CASES), help="comma-separated subset of: " + ", ".join(CASES))
    ap.add_argument("--device", default="", help="passed to bsdfmix --device")
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    cases = [c for c in args.cases.split(",") if c]
    for c in cases:
        if c not in CASES:
            sys.exit("failure_map.py: unknown case '%s' (expected one of %s)" % (c, ", ".join(CASES)))
    results = []
    with open(os.path.join(args.out, "failure_map.log"), "w") as log:
        for c in cases:
            r = run_case(c, args, log)
            log.flush()
            results.append(r)
            print("%-14s L1 %-9s K %-6s fit %-28s converge %-10s NaN %d  %s (%.0f s)" % (
                c, fmt(r.get("l1_rel", float("nan"))), r.get("k", "-"), r.get("fit_status", "?")[:28],
                r.get("converge_status", "?")[:10], r.get("nan_total", 0), r["verdict"], r.get("seconds", 0)),
                flush=True)
    cols = ["case", "fit_status", "converge_status", "l1_rel", "k", "iterations", "nan_total", "nan_mixture",
            "nan_report", "nan_search", "nan_convergence", "nan_tail"] + \
           ["mse_ratio_" + e for e in ESTIMATORS] + ["bias_z_" + e for e in ESTIMATORS] + \
           ["bias_rel_" + e for e in ESTIMATORS] + \
           ["relvar_is_over_us", "max_weight_is", "max_weight_mis", "stand_in_error", "biased_table_estimators",
            "mixture_problems", "verdict", "seconds"]
    with open(os.path.join(args.out, "failure_map.csv"), "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(cols)
        for r in results:
            w.writerow([fmt(r.get(c, "")) for c in cols])
    chart(results, args.out)
    print("wrote %s/failure_map.csv, failure_map.png, failure_map.svg, failure_map.log" % args.out)
    return 0 if all(r["verdict"] == "pass" for r in results) else 1


if __name__ == "__main__":
    sys.exit(main())
