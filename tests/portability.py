#!/usr/bin/python3
"""Every kernel a fit, a sample and the convergence study run (and inspect, compare and
pack) on a second OpenCL implementation: oclgrind (Debian's oclgrind), which simulates a GPU-like device and checks
every memory access, API call and data race. Run twice: oclgrind's own limits, and a
GPU-like profile (work-group 256, local memory 32 KiB, global memory small enough that a
fit's work is split into several batches). Any report of oclgrind fails, as does a
non-zero exit; the fit must agree with PoCL's (the same K per slice, relative L1 within
0.5 points). With fp64, equal-area fits run too: the silk table on the cylinder and a small
import of paper_white on the disk (fit.map: equal_area), each agreeing with PoCL's and sampled.

    /usr/bin/python3 tests/portability.py --bsdfmix build/bsdfmix [--keep DIR]
"""
import argparse
import csv
import os
import shutil
import subprocess
import sys
import tempfile

PROFILES = {
    "oclgrind": [],
    # 96 KiB of global memory: a batch may hold 96 KiB / 16 point-components (docs/studies/em_kernels.md),
    # so the fit's problems are cut into many batches.
    "gpu-like": ["--max-wgsize", "256", "--local-mem-size", "32768", "--global-mem-size", str(96 * 1024)],
}

FIT = """table: {table}
fit:
  output: {out}/mixture.h5
  report: {out}/fit.csv
  search_report: {out}/search.csv
  k_min: 1
  k_max: 3
  restarts: 1
  final_restarts: 1
  iterations: 8
  final_iterations: 8
  refine_evaluations: 4
  batch: 1  # two batches: PoCL fits them side by side, oclgrind one at a time
converge:
  theta_o: [0.5]
  samples_max: 64
  runs: 2
  csv: {out}/convergence.csv
  estimators: [is_gmm, mis_tab, cdf_tab]
"""


def fail(msg):
    sys.exit("portability: " + msg)


def icd_dir(tmp):
    """A vendors folder listing oclgrind alone (OCL_ICD_VENDORS), for the PoCL-free runs."""
    lib = "/usr/lib/oclgrind/liboclgrind-rt-icd.so"
    if not os.path.exists(lib):
        fail("oclgrind is not installed (scripts/setup installs it: apt-get install oclgrind)")
    d = os.path.join(tmp, "icd")
    os.makedirs(d, exist_ok=True)
    with open(os.path.join(d, "oclgrind.icd"), "w") as f:
        f.write(lib + "\n")
    return d


def run(cmd, env, log=None):
    r = subprocess.run(cmd, env=env, capture_output=True, text=True)
    if r.returncode != 0:
        fail("exit %d from %s\n%s%s" % (r.returncode, " ".join(cmd), r.stdout[-3000:], r.stderr[-3000:]))
    if log is not None and os.path.exists(log) and os.path.getsize(log) > 0:
        fail("oclgrind reported problems in %s:\n%s" % (" ".join(cmd), open(log).read()[:4000]))
    return r.stdout


def equal_area_config(cfg, table, out):
    """The portability fit's config on `table` in the equal-area map, writing under `out`."""
    os.makedirs(out, exist_ok=True)
    text = FIT.format(table=table, out=out).split("converge:")[0] + "  map: equal_area\n"
    with open(cfg, "w") as f:
        f.write(text)
    return cfg


def agree(what, expected, got):
    for s, (k, l1) in expected.items():
        gk, gl1 = got[s]
        if gk != k or abs(gl1 - l1) > 0.005:
            fail("%s: slice %d fitted K %d, L1 %.4f; PoCL K %d, L1 %.4f" % (what, s, gk, gl1, k, l1))


def report(path):
    return {int(r["slice"]): (int(r["k"]), float(r["l1_rel"])) for r in csv.DictReader(open(path))}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--bsdfmix", required=True)
    ap.add_argument("--keep", help="keep the work files in this folder")
    ap.add_argument("--profiles", default=",".join(PROFILES))
    a = ap.parse_args()
    exe = os.path.abspath(a.bsdfmix)
    tmp = a.keep or tempfile.mkdtemp(prefix="bsdfmix_portability_")
    os.makedirs(tmp, exist_ok=True)
    base = dict(os.environ)
    base.pop("BSDFMIX_DEVICE", None)
    base.pop("BSDFMIX_SHAPES", None)
    og_env = dict(base, OCL_ICD_VENDORS=icd_dir(tmp))

    # The check itself can fail: a self-test kernel that reads past its buffer and races in
    # local memory (loaded from a copy of kernels/ through BSDFMIX_KERNEL_DIR) must be reported.
    broken = os.path.join(tmp, "broken_kernels")
    shutil.copytree(os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "kernels"), broken,
                    dirs_exist_ok=True)
    path = os.path.join(broken, "selftest.cl")
    text = open(path).read()
    bad = text.replace("if (i < n) y[i] = a * x[i] + y[i];", "if (i < n) y[i] = a * x[i + 1] + y[i];")
    bad = bad.replace("if (lid < s) scratch[lid] += scratch[lid + s];", "scratch[lid] += scratch[(lid + s) % WGS];")
    if bad.count("x[i + 1]") != 1 or "% WGS" not in bad:
        fail("tests/portability.py no longer matches kernels/selftest.cl: update its broken copy")
    open(path, "w").write(bad)
    log = os.path.join(tmp, "broken.log")
    subprocess.run(["oclgrind", "--data-races", "--log", log, exe, "devices", "--check", "-q"],
                   env=dict(og_env, BSDFMIX_KERNEL_DIR=broken), capture_output=True, text=True)
    found = open(log).read() if os.path.exists(log) else ""
    if "Invalid read" not in found or "race" not in found.lower():
        fail("oclgrind did not report the broken self-test's out-of-bounds read and data race:\n" + found[:2000])
    print("portability: oclgrind reports a broken kernel (out-of-bounds read, data race)")

    # The PoCL fit the others must agree with (the table from the fiber kernel on PoCL).
    table = os.path.join(tmp, "silk.h5")
    run([exe, "generate", "fiber", "--preset", "silk", "--theta-o", "2", "--theta-i", "12", "--phi-i", "24",
         "--h-nodes", "16", "-o", table, "-q"], base)
    pocl = os.path.join(tmp, "pocl")
    os.makedirs(pocl, exist_ok=True)
    with open(os.path.join(pocl, "fit.yaml"), "w") as f:
        f.write(FIT.format(table=table, out=pocl))
    run([exe, "fit", os.path.join(pocl, "fit.yaml"), "-q"], base)
    expected = report(os.path.join(pocl, "fit.csv"))
    # The equal-area fits PoCL makes: silk on the cylinder, paper_white (2 x 8 x 16) on the disk.
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    paper = os.path.join(tmp, "paper.h5")
    run([exe, "import", "rgl", os.path.join(root, "data", "rgl", "paper_white_rgb.bsdf"), "--theta-o", "2",
         "--theta-i", "8", "--phi-i", "16", "-o", paper, "-q"], base)
    mapped = {}
    for label, t in (("silk", table), ("paper", paper)):
        d = os.path.join(pocl, "ea_" + label)
        run([exe, "fit", equal_area_config(os.path.join(tmp, "ea_%s.yaml" % label), t, d), "-q"], base)
        mapped[label] = (t, report(os.path.join(d, "fit.csv")))

    for name in a.profiles.split(","):
        flags = PROFILES[name]
        for precision in ("fp64", "fp32"):
            out = os.path.join(tmp, name + "_" + precision)
            os.makedirs(out, exist_ok=True)
            env = dict(og_env, BSDFMIX_PRECISION=precision)
            step = [0]

            def og(*args):
                step[0] += 1
                log = os.path.join(out, "oclgrind_%d.log" % step[0])
                return run(["oclgrind", "--data-races", "--check-api", "--log", log] + flags + [exe] + list(args) + ["-q"],
                           env, log)

            if precision == "fp64":
                og("devices", "--check")
            own = os.path.join(out, "silk.h5")
            og("generate", "fiber", "--preset", "silk", "--theta-o", "2", "--theta-i", "12", "--phi-i", "24",
               "--h-nodes", "16", "-o", own)
            cfg = os.path.join(out, "fit.yaml")
            with open(cfg, "w") as f:
                f.write(FIT.format(table=table, out=out))
            og("fit", cfg)
            got = report(os.path.join(out, "fit.csv"))
            agree("%s %s" % (name, precision), expected, got)
            if precision == "fp64":
                for label, (t, want) in mapped.items():  # the equal-area kernels (-DMAP), fitted and sampled
                    d = os.path.join(out, "ea_" + label)
                    og("fit", equal_area_config(os.path.join(out, "ea_%s.yaml" % label), t, d))
                    agree("%s %s equal_area %s" % (name, precision, label), want, report(os.path.join(d, "fit.csv")))
                    og("sample", os.path.join(d, "mixture.h5"), "--theta-o", "0.5", "-n", "256", "-o",
                       os.path.join(d, "samples.csv"))
                    print("portability: %s %s: equal_area %s clean" % (name, precision, label))
                og("sample", os.path.join(out, "mixture.h5"), "--theta-o", "0.5", "-n", "256", "-o",
                   os.path.join(out, "samples.csv"))
                og("converge", cfg)
                # the commands without kernels exit 0 too under oclgrind
                og("inspect", os.path.join(out, "mixture.h5"))
                og("compare", os.path.join(out, "mixture.h5"), table, "--csv", os.path.join(out, "compare.csv"))
                og("pack", os.path.join(out, "mixture.h5"), "-o", os.path.join(out, "packed.h5"), "--storage", "ragged_f32")
            print("portability: %s %s: clean, %s" % (name, precision,
                  ", ".join("slice %d K %d L1 %.4f (PoCL %.4f)" % (s, got[s][0], got[s][1], expected[s][1]) for s in sorted(got))))
    if not a.keep:
        shutil.rmtree(tmp)
    print("portability: every command exited 0 with no oclgrind report")


if __name__ == "__main__":
    main()
