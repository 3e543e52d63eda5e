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

from peer_protocol import Peer  # first: pins the thread pools before numpy loads

import sys
import time
import warnings

PEER = Peer("scikit-learn", "scikit-learn EM peer timing", min_k=1)
fail = PEER.fail
IMPL = PEER.impl


def main():
    args = PEER.parse_args()

    try:
        import numpy
        import sklearn
        from sklearn.exceptions import ConvergenceWarning
        from sklearn.mixture import GaussianMixture
    except ImportError as e:
        fail("not installed (%s)" % e, 3)

    warnings.filterwarnings("ignore", category=ConvergenceWarning)

    X, w = PEER.load_cells(numpy, args)

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
