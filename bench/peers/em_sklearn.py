#!/usr/bin/python3
"""Peer EM timing: full-covariance 2D GMM with scikit-learn's GaussianMixture.

Usage: em_sklearn.py --data FILE --n N --k K --iterations I --seed S [--verbose]

Prints one CSV line on stdout:
    scikit-learn,K,N,I,seconds_per_iteration
Exit status: 0 success, 3 scikit-learn/numpy not installed, 1 any other error.

GaussianMixture has no sample weights, so the fit runs unweighted on the same
N points (theta, phi), zero-weight cells included: the arithmetic per
point-component is the same as in a weighted E/M step.

What is timed: GaussianMixture.fit(X) with covariance_type='full',
max_iter=I, tol=0 (the stop test is |change| < tol, which never holds), n_init=1,
warm_start=True on a model already initialised by a first, untimed fit
(init_params='kmeans', random_state=S, max_iter=1).  With warm_start the second
fit skips initialisation and runs exactly I iterations (n_iter_ is checked);
each iteration is an E-step, an M-step (per-component covariance and Cholesky
of the precision) and the lower-bound update, and fit adds one final E-step
after the loop.  Reported value: fit wall time / n_iter_.  With --verbose the
time from the first E-step to the end of the I-th M-step (exact I iterations)
is also printed on stderr.

Threading: OMP/OpenBLAS/MKL thread variables are set to 1 before numpy is
imported (the EM loop itself is numpy/BLAS code; k-means init is untimed).
"""

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS",
             "BLIS_NUM_THREADS", "VECLIB_MAXIMUM_THREADS", "NUMEXPR_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse
import sys
import time
import warnings

IMPL = "scikit-learn"


def fail(msg, code=1):
    sys.stderr.write("%s: %s\n" % (IMPL, " ".join(str(msg).split())))
    sys.exit(code)


class _Parser(argparse.ArgumentParser):
    def error(self, message):
        fail("usage error: " + message)


def parse_args():
    p = _Parser(description="scikit-learn EM peer timing")
    p.add_argument("--data", required=True)
    p.add_argument("--n", type=int, required=True)
    p.add_argument("--k", type=int, required=True)
    p.add_argument("--iterations", type=int, required=True)
    p.add_argument("--seed", type=int, required=True)
    p.add_argument("--verbose", action="store_true")
    a = p.parse_args()
    if a.n <= 0:
        fail("--n must be positive")
    if a.k < 1 or a.k > a.n:
        fail("--k must be in [1, n]")
    if a.iterations <= 0:
        fail("--iterations must be positive")
    if a.seed < 0 or a.seed >= 2 ** 32:
        fail("--seed must be in [0, 2^32)")
    return a


def main():
    args = parse_args()

    try:
        import numpy
        import sklearn
        from sklearn.exceptions import ConvergenceWarning
        from sklearn.mixture import GaussianMixture
    except ImportError as e:
        fail("not installed (%s)" % e, 3)

    warnings.filterwarnings("ignore", category=ConvergenceWarning)

    try:
        raw = numpy.fromfile(args.data, dtype="<f4")
    except (OSError, ValueError) as e:
        fail("cannot read %s: %s" % (args.data, e))
    if raw.size != 3 * args.n:
        fail("%s holds %d float32 values, expected 3 x %d" % (args.data, raw.size, args.n))
    cells = raw.reshape(args.n, 3).astype(numpy.float64)
    if not numpy.isfinite(cells).all():
        fail("data must be finite")
    X = numpy.ascontiguousarray(cells[:, 0:2])

    # Stamps only; the E/M steps are the library's own.
    class TimedGM(GaussianMixture):
        stamps = None

        def _e_step(self, X):
            if self.stamps is not None and not self.stamps:
                self.stamps.append(time.perf_counter())
            return super()._e_step(X)

        def _m_step(self, X, log_resp):
            r = super()._m_step(X, log_resp)
            if self.stamps is not None:
                self.stamps.append(time.perf_counter())
            return r

    try:
        gm = TimedGM(n_components=args.k, covariance_type="full", tol=0.0,
                     max_iter=1, n_init=1, init_params="kmeans",
                     random_state=args.seed, warm_start=True)
        gm.fit(X)  # initialisation + 1 iteration, untimed

        gm.max_iter = args.iterations
        gm.stamps = []
        t0 = time.perf_counter()
        gm.fit(X)
        t1 = time.perf_counter()
        stamps = gm.stamps
        gm.stamps = None
    except Exception as e:  # any library failure is a plain error
        fail("fit failed: %s: %s" % (type(e).__name__, e))

    if gm.n_iter_ != args.iterations:
        fail("fit ran %d iterations, expected %d" % (gm.n_iter_, args.iterations))
    if not numpy.isfinite(gm.lower_bound_):
        fail("lower bound is not finite after %d iterations" % gm.n_iter_)

    per_iter = (t1 - t0) / gm.n_iter_
    if args.verbose:
        exact = ((stamps[-1] - stamps[0]) / args.iterations
                 if len(stamps) == args.iterations + 1 else float("nan"))
        sys.stderr.write(
            "%s %s: fit %.6f s, n_iter_ %d; E/M loop only %.6e s/iter; "
            "lower bound %.6f\n"
            % (IMPL, sklearn.__version__, t1 - t0, gm.n_iter_, exact, gm.lower_bound_))
    sys.stdout.write("%s,%d,%d,%d,%.9g\n" % (IMPL, args.k, args.n, gm.n_iter_, per_iter))
    return 0


if __name__ == "__main__":
    sys.exit(main())
