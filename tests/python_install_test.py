"""The Python module installs as Python users expect: in a fresh virtual environment that sees
Debian's packages, offline, from python/ (python/setup.py), then imports and evaluates a mixture
file exactly as the module built by CMake does. Run by ctest (python_install_test):

    /usr/bin/python3 tests/python_install_test.py MIXTURE.h5

It runs `python3 -m venv --system-site-packages V` and
`V/bin/python -m pip install --no-build-isolation --no-index ./python` in $TMPDIR, builds the
objects there (BSDFMIX_PY_BUILD), and exits 1 with the failing step's output on any failure.
"""
import os
import pathlib
import subprocess
import sys
import tempfile

ROOT = pathlib.Path(__file__).resolve().parent.parent

# In the venv: the installed module (not a build folder on the path) loads the file and gives
# eval_f and samples; printed for the comparison below.
PROBE = r"""
import sys, bsdfmix
assert "site-packages" in bsdfmix.__file__, bsdfmix.__file__
m = bsdfmix.load_mixture(sys.argv[1])
theta, phi, pdf, valid = m.sample_counter(0.3, 1.1, 5, seed=7)
print(repr(float(m.eval_f(0.3, 1.1, 0.2, 0.4))), [repr(float(x)) for x in theta])
"""


def run(cmd, env=None):
    r = subprocess.run(cmd, capture_output=True, text=True, env=env)
    if r.returncode != 0:
        sys.exit("python_install_test: `%s` failed (%d):\n%s%s" % (" ".join(map(str, cmd)), r.returncode,
                                                                   r.stdout[-4000:], r.stderr[-4000:]))
    return r.stdout


def main():
    if len(sys.argv) != 2:
        sys.exit("usage: python_install_test.py MIXTURE.h5")
    mixture = sys.argv[1]
    with tempfile.TemporaryDirectory(prefix="bsdfmix_install_") as tmp:
        venv = pathlib.Path(tmp) / "venv"
        run(["/usr/bin/python3", "-m", "venv", "--system-site-packages", str(venv)])
        env = dict(os.environ, BSDFMIX_PY_BUILD=str(pathlib.Path(tmp) / "build"), PYTHONPATH="")
        env.pop("BSDFMIX_MODULE_DIR", None)
        run([str(venv / "bin" / "python"), "-m", "pip", "install", "-q", "--no-build-isolation", "--no-index",
             str(ROOT / "python")], env)
        installed = run([str(venv / "bin" / "python"), "-c", PROBE, mixture], env)
    # The module CMake built (BSDFMIX_MODULE_DIR, as the other Python tests) gives the same numbers.
    built = run(["/usr/bin/python3", "-c", "import sys; sys.path.insert(0, %r)\n" % os.environ["BSDFMIX_MODULE_DIR"]
                 + PROBE.replace('assert "site-packages"', 'assert "site-packages" not'), mixture])
    if installed != built:
        sys.exit("python_install_test: the installed module gives %s, the CMake build's %s" % (installed, built))
    print("python_install_test: pip installed bsdfmix into a venv; it loads and samples as the CMake build's: "
          + installed.strip())


if __name__ == "__main__":
    main()
