// L1 refinement: moves a fitted mixture toward the least relative L1 error of its
// stand-in (the error the sweep scores and the file reports), where EM maximizes the
// likelihood instead. docs/fitting.md, "L1 refinement".
//
// The objective of a mixture g on a slice of weights w (normalized to sum 1) over cells
// of area A is F = sum_i sqrt(d_i^2 + eps^2) + kl sum_i w_i log(w_i / (A g(x_i))),
// d_i = w_i - A g(x_i): the relative L1 error, smoothed within eps of zero so that it has
// a gradient, plus kl times the Kullback-Leibler divergence that EM minimizes (it keeps
// the mixture covering the slice's tails, which the L1 error alone would trade for a
// closer core: the variance of importance sampling by the mixture grows where it
// does). Its gradient follows from six sums per component (the statistics of EM's
// M-step, with s_i = d_i / rho_i + kl w_i / (A g(x_i)) times the component's density in
// place of a responsibility), computed on the device by
// kernels/em.cl em_l1 (EmEngine::l1_values) or in double by l1_values_reference.
// A batched L-BFGS (refine_l1) walks every problem of a batch together: one evaluation
// of all of them per device call.
#pragma once

#include <cstddef>
#include <functional>
#include <vector>

#include "fit/gmm.hpp"
#include "fit/slices.hpp"

namespace bsdfmix {

// One mixture on one slice of a set.
struct L1Query {
  std::size_t slice = 0;
  Gmm gmm;
};

// The objective and, per component j of K, stats[q * K + j] for q = 0..5: the sums of
// s_i pi_j N_j(x_i) times 1, dt, dp, dt^2, dt dp, dp^2 (offsets from the mean, per image).
struct L1Value {
  double objective = 0;
  std::vector<double> stats;
};

// The objective's constants: eps, the smoothing (1e-3 of the mean cell weight, from
// l1_objective), and kl, the weight of the divergence.
struct L1Objective {
  double eps = 0, kl = 0;
};
L1Objective l1_objective(const SliceGrid& grid, double kl);

// The phi images on each side of the nearest one that a component of phi variance
// s_pp needs (those within 6 standard deviations of some phi in [-pi, pi)).
int l1_images(double s_pp);

// The CPU reference (double precision).
std::vector<L1Value> l1_values_reference(const SliceSet& set, const std::vector<L1Query>& queries,
                                         const L1Objective& objective);

using L1Evaluator =
    std::function<std::vector<L1Value>(const SliceSet&, const std::vector<L1Query>&, const L1Objective&)>;

// The gradient of the objective with respect to each component's weight, mean and
// covariance, from an evaluation: grad[6 j + 0] d/d pi_j, [1], [2] d/d mean,
// [3..5] d/d (s_tt, s_tp, s_pp) for the symmetric matrix (dF = tr(G dSigma)).
std::vector<double> l1_gradient(const SliceGrid& grid, const Gmm& gmm, const L1Value& v);

struct RefineSettings {
  int evaluations = 150;  // objective evaluations per problem (device calls), at most
  double kl = 5.0;       // weight of the Kullback-Leibler divergence beside the L1 error
};

// Refines every query's mixture (same K) toward the least objective, starting
// from it. Covariances stay at or above (half the smaller cell step)^2 (narrower
// components are widened to it first): the table does not resolve narrower ones, and the
// stand-in is compared by its density at the cell centers. Returns one mixture per
// query: the best point the walk reached (the start when nothing was better).
std::vector<Gmm> refine_l1(const L1Evaluator& evaluate, const SliceSet& set, const std::vector<L1Query>& start,
                           const RefineSettings& settings);

}  // namespace bsdfmix
