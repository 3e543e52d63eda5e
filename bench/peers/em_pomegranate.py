#!/usr/bin/python3
"""Peer EM timing: weighted full-covariance 2D GMM with pomegranate 0.14.

Usage: em_pomegranate.py --data FILE --n N --k K --iterations I --seed S [--verbose]

Prints one CSV line on stdout:
    pomegranate,K,N,I,seconds_per_iteration
Exit status: 0 success, 3 pomegranate/numpy not installed, 1 any other error.

What is timed: one call of GeneralMixtureModel.fit(X, weights=w,
max_iterations=I, stop_threshold=-inf) on an already initialised model.
pomegranate's fit loop does, per epoch, from_summaries() (M-step) followed by
summarize() (E-step + sufficient statistics + log-likelihood); epoch 0 has no
stored statistics, so its M-step is a no-op.  One fit with max_iterations=I is
therefore I full M+E iterations plus one leading E-step, and the reported
value is the fit wall time divided by I.  The exact steady-state time of the I
iterations (end of the leading E-step to end of the last E-step) is also
measured and printed on stderr with --verbose.

Initialisation (excluded from timing): GeneralMixtureModel.from_samples with
pomegranate's own weighted k-means++ seeding (1 k-means iteration) and one EM
iteration, seeded through numpy.random.seed(S) (pomegranate's k-means uses the
global numpy RandomState).

Threading: n_jobs=1 (joblib runs the batches sequentially); the BLAS thread
variables are set to 1 before numpy is imported.
"""

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS",
             "BLIS_NUM_THREADS", "VECLIB_MAXIMUM_THREADS", "NUMEXPR_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse
import sys
import time

IMPL = "pomegranate"


def fail(msg, code=1):
    sys.stderr.write("%s: %s\n" % (IMPL, " ".join(str(msg).split())))
    sys.exit(code)


class _Parser(argparse.ArgumentParser):
    def error(self, message):
        fail("usage error: " + message)


def parse_args():
    p = _Parser(description="pomegranate weighted-EM peer timing")
    p.add_argument("--data", required=True)
    p.add_argument("--n", type=int, required=True)
    p.add_argument("--k", type=int, required=True)
    p.add_argument("--iterations", type=int, required=True)
    p.add_argument("--seed", type=int, required=True)
    p.add_argument("--verbose", action="store_true")
    a = p.parse_args()
    if a.n <= 0:
        fail("--n must be positive")
    if a.k < 2:
        fail("--k must be at least 2 (pomegranate mixtures need two components)")
    if a.k > a.n:
        fail("--k must not exceed --n")
    if a.iterations <= 0:
        fail("--iterations must be positive")
    if a.seed < 0 or a.seed >= 2 ** 32:
        fail("--seed must be in [0, 2^32)")
    return a


def main():
    args = parse_args()

    try:
        import numpy
        import pomegranate
        from pomegranate import GeneralMixtureModel, MultivariateGaussianDistribution
        from pomegranate.bayes import BayesModel
    except ImportError as e:
        fail("not installed (%s)" % e, 3)

    try:
        raw = numpy.fromfile(args.data, dtype="<f4")
    except (OSError, ValueError) as e:
        fail("cannot read %s: %s" % (args.data, e))
    if raw.size != 3 * args.n:
        fail("%s holds %d float32 values, expected 3 x %d" % (args.data, raw.size, args.n))
    cells = raw.reshape(args.n, 3).astype(numpy.float64)
    X = numpy.ascontiguousarray(cells[:, 0:2])
    w = numpy.ascontiguousarray(cells[:, 2])
    if not (numpy.isfinite(cells).all() and (w >= 0).all() and w.sum() > 0):
        fail("data must be finite with weights >= 0 and a positive total")

    # summarize() is looked up on the instance by fit(), so a Python subclass
    # can stamp the end of each E-step without changing what is computed.
    # GeneralMixtureModel.__init__ calls super(self.__class__, ...), which
    # recurses in a subclass; it only forwards to BayesModel.__init__.
    class TimedGMM(GeneralMixtureModel):
        def __init__(self, distributions, weights=None):
            BayesModel.__init__(self, distributions, weights)

        def summarize(self, X, weights=None):
            r = GeneralMixtureModel.summarize(self, X, weights)
            stamps = getattr(self, "stamps", None)
            if stamps is not None:
                stamps.append(time.perf_counter())
            return r

    try:
        numpy.random.seed(args.seed)
        model = TimedGMM.from_samples(
            MultivariateGaussianDistribution, n_components=args.k, X=X, weights=w,
            n_init=1, init="kmeans++", max_kmeans_iterations=1,
            max_iterations=1, stop_threshold=-numpy.inf, n_jobs=1)

        model.stamps = []
        t0 = time.perf_counter()
        _, history = model.fit(X, weights=w, max_iterations=args.iterations,
                               stop_threshold=-numpy.inf, return_history=True,
                               n_jobs=1)
        t1 = time.perf_counter()
        stamps = model.stamps
        model.stamps = None
    except Exception as e:  # any library failure is a plain error
        fail("fit failed: %s: %s" % (type(e).__name__, e))

    epochs = list(history.epochs)
    if epochs != list(range(1, args.iterations + 1)):
        fail("fit ran epochs %s, expected 1..%d" % (epochs[:3] + ["..."] + epochs[-2:],
                                                   args.iterations))
    if len(stamps) != args.iterations + 1:
        fail("fit ran %d E-steps, expected %d" % (len(stamps), args.iterations + 1))
    if not numpy.isfinite(history.log_probabilities[-1]):
        fail("log-likelihood is not finite after %d iterations" % args.iterations)

    per_iter = (t1 - t0) / args.iterations
    if args.verbose:
        steady = (stamps[-1] - stamps[0]) / args.iterations
        sys.stderr.write(
            "%s %s: fit %.6f s for %d epochs (+1 leading E-step); "
            "steady-state %.6e s/iter; final log-likelihood %.6f\n"
            % (IMPL, pomegranate.__version__, t1 - t0, len(epochs), steady,
               history.log_probabilities[-1]))
    sys.stdout.write("%s,%d,%d,%d,%.9g\n" % (IMPL, args.k, args.n, args.iterations, per_iter))
    return 0


if __name__ == "__main__":
    sys.exit(main())
