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

from peer_protocol import Peer  # first: pins the thread pools before numpy loads

import sys
import time

PEER = Peer("pomegranate", "pomegranate weighted-EM peer timing", min_k=2)
fail = PEER.fail
IMPL = PEER.impl


def main():
    args = PEER.parse_args()

    try:
        import numpy
        import pomegranate
        from pomegranate import GeneralMixtureModel, MultivariateGaussianDistribution
        from pomegranate.bayes import BayesModel
    except ImportError as e:
        fail("not installed (%s)" % e, 3)

    X, w = PEER.load_cells(numpy, args)

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
