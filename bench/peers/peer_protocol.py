"""The peer protocol shared by the Python EM peers (bench/peers/README.md).

Importing this module pins every BLAS/OpenMP thread pool to one thread, so it must be
imported before numpy.
"""

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS",
             "BLIS_NUM_THREADS", "VECLIB_MAXIMUM_THREADS", "NUMEXPR_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import sys  # noqa: E402


class Peer:
    """One peer program: its name for messages, argument parsing, the data file."""

    def __init__(self, impl, description, min_k=1):
        self.impl = impl
        self.description = description
        self.min_k = min_k

    def fail(self, msg, code=1):
        sys.stderr.write("%s: %s\n" % (self.impl, " ".join(str(msg).split())))
        sys.exit(code)

    def parse_args(self):
        peer = self

        class Parser(argparse.ArgumentParser):
            def error(self, message):
                peer.fail("usage error: " + message)

        p = Parser(description=self.description)
        p.add_argument("--data", required=True)
        p.add_argument("--n", type=int, required=True)
        p.add_argument("--k", type=int, required=True)
        p.add_argument("--iterations", type=int, required=True)
        p.add_argument("--seed", type=int, required=True)
        p.add_argument("--verbose", action="store_true")
        a = p.parse_args()
        if a.n <= 0:
            self.fail("--n must be positive")
        if a.k < self.min_k:
            self.fail("--k must be at least %d" % self.min_k +
                      (" (pomegranate mixtures need two components)" if self.min_k == 2 else ""))
        if a.k > a.n:
            self.fail("--k must not exceed --n")
        if a.iterations <= 0:
            self.fail("--iterations must be positive")
        if a.seed < 0 or a.seed >= 2 ** 32:
            self.fail("--seed must be in [0, 2^32)")
        return a

    def load_cells(self, numpy, args):
        """The N (theta, phi, weight) cells as float64 arrays X (N x 2) and w (N)."""
        try:
            raw = numpy.fromfile(args.data, dtype="<f4")
        except (OSError, ValueError) as e:
            self.fail("cannot read %s: %s" % (args.data, e))
        if raw.size != 3 * args.n:
            self.fail("%s holds %d float32 values, expected 3 x %d" % (args.data, raw.size, args.n))
        cells = raw.reshape(args.n, 3).astype(numpy.float64)
        X = numpy.ascontiguousarray(cells[:, 0:2])
        w = numpy.ascontiguousarray(cells[:, 2])
        if not (numpy.isfinite(cells).all() and (w >= 0).all() and w.sum() > 0):
            self.fail("data must be finite with weights >= 0 and a positive total")
        return X, w
