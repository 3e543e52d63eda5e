"""bench/README.md's "Results" block, from the newest `bsdfmix bench em` CSVs of
bench/results/ (scripts/doc_tables.py writes it between its markers)."""
import os
import re

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RESULTS = os.path.join(ROOT, "bench", "results")


from readme_measured import rows  # noqa: E402


def profile(txt):
    """The profile line of a run's stdout: (init s, iterations s, batches, final s) or None."""
    try:
        with open(os.path.join(RESULTS, txt)) as f:
            text = f.read()
    except OSError:
        return None
    m = re.search(r"host init ([\d.]+) s, iterations ([\d.]+) s over (\d+) batch\(es\), "
                  r"final log-likelihood and read-back ([\d.]+) s", text)
    if not m:
        return None
    setup = re.search(r"batch setup \(not in s/iteration\) ([\d.]+) s", text)
    return m.groups() + ((setup.group(1),) if setup else (None,))


# The ceiling of the percentage by the kernel's flops per update (bench/README.md): the flops over
# twice the arithmetic instructions, 45 / 66 before the offsets were kept and the exp2 degree lowered.
CAP = {"45": "68", "39": "70"}

LABEL = {"armadillo": "armadillo (`-O3 -march=native`)", "armadillo_generic": "armadillo_generic (`-O3`)"}


def table(name):
    all_rows = rows(name)
    ours = next(r for r in all_rows if r["impl"].startswith("bsdfmix"))
    per = lambda r: float(r["seconds_per_iteration"]) / int(r["slices"])
    out = ["| impl | threads | slices | s/iteration | ms per slice-iteration | G pc/s | bsdfmix / row |",
           "|---|---|---|---|---|---|---|"]
    for r in all_rows:
        out.append("| %s | %s | %s | %s | %.4g | %.3g | %.0f |" % (
            LABEL.get(r["impl"], r["impl"]), r["threads"], r["slices"], r["seconds_per_iteration"], 1e3 * per(r),
            float(r["pc_per_s"]) / 1e9, per(r) / per(ours)))
    return out, all_rows, ours, per


def results(machine):
    """The block for em_k50_<machine>.csv and em_k16_<machine>.csv, as lines."""
    k50, k16 = "em_k50_%s.csv" % machine, "em_k16_%s.csv" % machine
    t50, r50, o50, per50 = table(k50)
    t16, _, o16, _ = table(k16)
    by = {r["impl"]: r for r in r50}
    speed = lambda impl: per50(by[impl]) / per50(o50) if impl in by else None
    arma = min((i for i in ("armadillo", "armadillo_generic") if i in by), key=lambda i: per50(by[i]), default=None)
    named = [("the faster Armadillo build", arma), ("pomegranate", "pomegranate"),
             ("scikit-learn", "scikit-learn"), ("its own one-thread CPU reference", "cpu_reference")]
    named = [(w, i) for w, i in named if i in by]
    lines = ["Machine (CSV columns): `%s`, %s logical CPUs, OpenCL device `%s`, %s slices, %s iterations (s/iteration: "
             "the difference of fits of that many and 1, over one less), fp64 "
             "accumulation (stdout profile line), best of %s rounds. 1-minute load average before the K = 50 run %s, "
             "before the K = 16 run %s." % (o50["cpu_model"], o50["logical_cpus"], o50["opencl_device"], o50["slices"],
                                            o50["iterations"], o50["reps"], o50["loadavg_before"],
                                            o16["loadavg_before"]),
             "", "K = 50 (`bench/results/%s`):" % k50, ""] + t50
    if o50.get("pct_of_fma_peak"):
        lines += ["", "%s flops per update x %.3g G/s = %s GFLOP/s: %s%% of the measured FMA peak of %s GFLOP/s (%s, "
                  "every logical CPU); the kernel's instruction mix caps it at about %s%% (above)." % (
                      o50["flops_per_update"], float(o50["pc_per_s"]) / 1e9, o50["gflops"], o50["pct_of_fma_peak"],
                      o50["fma_peak_gflops"], o50["fma_peak_isa"], CAP.get(o50["flops_per_update"], "?"))]
    lines += ["", "K = 16 (`bench/results/%s`):" % k16, ""] + t16
    if o16.get("pct_of_fma_peak"):
        lines += ["", "%s GFLOP/s: %s%% of the measured peak of %s GFLOP/s." % (
            o16["gflops"], o16["pct_of_fma_peak"], o16["fma_peak_gflops"])]
    lines += ["", "Per slice-iteration (the same work in every row) bsdfmix is, at K = 50, %s. bsdfmix runs on %s "
              "logical CPUs and every other row on one; divided by that, the ratios are %s." % (
                  ", ".join("%.0fx faster than %s" % (speed(i), w) for w, i in named), o50["threads"],
                  ", ".join("%.0fx" % (speed(i) / int(o50["threads"])) for _, i in named))]
    if "armadillo" in by and "armadillo_generic" in by:
        lines += ["", "`-march=native` made Armadillo %s on this machine (%s against %s s per iteration at K = 50), "
                  "hence both rows; the ratios use the faster one." % (
                      "slower" if per50(by["armadillo"]) > per50(by["armadillo_generic"]) else "faster",
                      by["armadillo"]["seconds_per_iteration"], by["armadillo_generic"]["seconds_per_iteration"])]
    p = profile(k50.replace(".csv", ".txt"))
    if p:
        lines += ["", "The profile line of the K = 50 run (stdout, `bench/results/%s`): host initialization %s s, %s "
                  "iterations %s s in %s batches, final log-likelihood and read-back %s s%s." % (
                      k50.replace(".csv", ".txt"), p[0], o50["iterations"], p[1], p[2], p[3],
                      "; the batches' setup, not in s/iteration, %s s" % p[4] if p[4] else "")]
    return lines


def performance():
    """docs/em.md's "Performance" table: `bench em` at K 8, 16 and 50 (the newest CSVs), and the
    seconds per iteration against the previous kernels (em_speed.csv)."""
    import readme_measured
    speed = {int(r["k"]): r for r in rows("em_speed.csv") if r["what"] == "em_seconds_per_iteration"}
    out = ["| K | G updates/s | GFLOP/s | of the FMA peak | s per iteration, against the previous kernels | CSV |",
           "|---|---|---|---|---|---|"]
    for k in (8, 16, 50):
        name = readme_measured.em_file(k)
        o = next(r for r in rows(name) if r["impl"].startswith("bsdfmix"))
        s = speed.get(k)
        out.append("| %d | %.3g | %s | %s%% | %s | [%s](../bench/results/%s) |" % (
            k, float(o["pc_per_s"]) / 1e9, o["gflops"], o["pct_of_fma_peak"],
            "%.2fx" % float(s["new_over_old"]) if s else "", name, name))
    return out


def fit_speed():
    """docs/em.md's default fits of the RGL files by two builds (fit_speed.csv)."""
    out = ["| material | seconds, before / now | speed-up | CPU use, before / now | L1 median, before / now | "
           "L1 p90, before / now |", "|---|---|---|---|---|---|"]
    pct = lambda x: "%.2f%%" % (100 * float(x))
    for r in rows("fit_speed.csv"):
        out.append("| %s | %s / %s | %.2fx | %.0f%% / %.0f%% | %s / %s | %s / %s |" % (
            r["material"], r["old_seconds"], r["new_seconds"], float(r["speedup"]), 100 * float(r["old_utilization"]),
            100 * float(r["new_utilization"]), pct(r["old_l1_median"]), pct(r["new_l1_median"]),
            pct(r["old_l1_p90"]), pct(r["new_l1_p90"])))
    return out


def fit_phases():
    """docs/studies/em_kernels.md's shares of a default fit's batch time by phase, the new build's (fit_speed.csv)."""
    out = ["| material | search | final EM | past a stalled walk | L1 refinement | the rest |",
           "|---|---|---|---|---|---|"]
    for r in rows("fit_speed.csv"):
        if r.get("new_search"):
            out.append("| %s | %s |" % (r["material"], " | ".join(
                "%.0f%%" % (100 * float(r["new_" + p])) for p in ("search", "final_em", "beyond", "refine", "rest"))))
    return out
