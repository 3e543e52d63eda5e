"""What the studies that drive the CLI share: running build/bsdfmix, reading and writing
their CSVs, and the per-view ratios of `bsdfmix bench sampling`'s CSV."""
import csv
import glob
import os
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
# BSDFMIX_BIN: another build of the CLI (a copy, so that rebuilding does not stop a long study)
BIN = os.environ.get("BSDFMIX_BIN") or os.path.join(ROOT, "build", "bsdfmix")


def bsdfmix(study, *args):
    """Runs `bsdfmix ARGS` (each as text); a failure ends the study with one line naming the command."""
    args = [str(a) for a in args]
    r = subprocess.run([BIN, *args], capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"{study}: `bsdfmix {' '.join(args)}` failed: {r.stderr.strip()}")


def measured(study, cmd, cwd=None, what=None, stdout=None):
    """Runs the command `cmd` (a list): its wall seconds, its CPU seconds (user + system) and
    its peak resident bytes, from os.wait4's rusage of that child alone; its output goes to the
    file `stdout` (default: nowhere). A failure ends the study with one line naming `what`
    (default: the command) and the last line of its stderr."""
    cmd = [str(c) for c in cmd]
    with open(stdout or os.devnull, "w") as null, tempfile.TemporaryFile("w+") as err:
        t = time.perf_counter()
        p = subprocess.Popen(cmd, stdout=null, stderr=err, cwd=cwd, text=True)
        _, status, use = os.wait4(p.pid, 0)
        wall = time.perf_counter() - t
        if os.waitstatus_to_exitcode(status) != 0:
            err.seek(0)
            last = (err.read().strip().splitlines() or ["?"])[-1]
            sys.exit(f"{study}: {what or '`' + ' '.join(cmd) + '`'} failed: {last}")
    return wall, use.ru_utime + use.ru_stime, use.ru_maxrss * 1024


def grid(study, text):
    """A table grid "theta_o,theta_i,phi_i" as three positive counts; else the study ends naming it."""
    n = [int(x) for x in text.split(",")]
    if len(n) != 3 or min(n) < 1:
        sys.exit(f"{study}: a grid is theta_o,theta_i,phi_i (got {text!r})")
    return n


def rgl_materials(text=""):
    """RGL material names (data/rgl/NAME_rgb.bsdf): those of the comma-separated `text`, else every shipped one."""
    return [m for m in text.split(",") if m] or sorted(
        os.path.basename(p)[:-len("_rgb.bsdf")] for p in glob.glob(os.path.join(ROOT, "data", "rgl", "*_rgb.bsdf")))


def rows(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def write_rows(path, out):
    """The rows (dicts with the same keys) as a CSV, written under a temporary name first."""
    tmp = path + ".tmp"
    with open(tmp, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(out[0].keys()))
        w.writeheader()
        w.writerows(out)
    os.replace(tmp, path)


def by_view(sampling_csv):
    """`bench sampling`'s rows under constant light: {theta_o_deg: {sampler: row}}."""
    by = {}
    for r in rows(sampling_csv):
        if r.get("lighting", "constant") == "constant":
            by.setdefault(r["theta_o_deg"], {})[r["sampler"]] = r
    return by


def over_rgl(by, sampler):
    """Per view, the sampler's variance per sample over the RGL file's own sampler's."""
    return [float(v[sampler]["relvar"]) / float(v["rgl"]["relvar"]) for v in by.values()]
