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
//
// With colour (a SliceSet with rgb and RefineSettings::rgb, the channels' share a > 0) the
// channels join the objective: (1 - a) L + a sum_c sum_i sqrt(e_ic^2 + eps^2) + kl KL, L the
// luminance's smoothed L1 error and KL the divergence above, e_ic = v_ic - A sum_j b_jc N_j(x_i),
// v_c the channel's weights over the sum of the three channels' absolute weights
// (l1_channels), b_jc >= 0 each component's amplitude in channel c, walked with the
// Gaussians and dropped after (the stand-in's amplitudes are fitted on the result,
// sweep/stand_in.hpp). The Gaussians stay one set, the luminance's weights the sampling
// density; what moves is where they sit, so that the channels' shapes are drawn too.
// (The evaluations take it over 1 - a: weights a / (1 - a) and kl / (1 - a), l1_weights.)
// A slice whose channels are the luminance's shape (l1_channels) has none: its objective
// is the luminance's alone.
#pragma once

#include <cstddef>
#include <functional>
#include <utility>
#include <vector>

#include "fit/gmm.hpp"
#include "fit/slices.hpp"

namespace bsdfmix {

// One mixture on one slice of a set; with channels, rgb_amp[c * K + j] = b_jc (empty: the
// luminance alone).
struct L1Query {
  L1Query() = default;
  L1Query(std::size_t slice_, Gmm gmm_, std::vector<double> rgb_amp_ = {})
      : slice(slice_), gmm(std::move(gmm_)), rgb_amp(std::move(rgb_amp_)) {}
  std::size_t slice = 0;
  Gmm gmm;
  std::vector<double> rgb_amp;
};

// The objective and, per component j of K, stats[q * K + j] for q = 0..5: the sums of
// s_i pi_j N_j(x_i) times 1, dt, dp, dt^2, dt dp, dp^2 (offsets from the mean, per image).
// With channels, q = 1..5 weigh pi_j N_j by s_i + sum_c (b_jc / pi_j) s_ic, q = 0 stays
// s_i's, and q = 6, 7, 8 are the sums of s_ic pi_j N_j(x_i) (s_ic = rgb e_ic / rho_ic).
struct L1Value {
  double objective = 0;
  std::vector<double> stats;
};

// The objective's constants: eps, the smoothing (1e-3 of the mean cell weight, from
// l1_objective), kl, the weight of the divergence, and rgb, the channels' share a of the
// L1 error (below 1) for the queries with amplitudes.
struct L1Objective {
  double eps = 0, kl = 0, rgb = 0;
};
L1Objective l1_objective(const SliceGrid& grid, double kl, double rgb = 0);

// The weights a query's evaluation takes: kl and 0 for the luminance alone; with channels,
// kl / (1 - a) and a / (1 - a) (the objective over 1 - a).
struct L1Weights {
  double kl = 0, rgb = 0;
};
L1Weights l1_weights(const L1Objective& objective, bool channels);

// Slice s's channels in the objective's units: set.rgb[s] over the sum of its absolute
// values (channel-major, 3 x cells); empty without colour, for an all-zero slice, and for
// channels of the luminance's shape: sum_c sum_i |v_ic - r_c w_i| at most kGreyShare of
// sum_c sum_i |v_ic|, r_c channel c's sum over the luminance's (set.weights[s]): the
// luminance's error is then theirs (a grey or undyed table).
constexpr double kGreyShare = 0.01;
std::vector<double> l1_channels(const SliceSet& set, std::size_t s);

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
// [3..5] d/d (s_tt, s_tp, s_pp) for the symmetric matrix (dF = tr(G dSigma)); with
// channels (rgb_amp not empty), then grad[6 K + c * K + j] d/d b_jc.
std::vector<double> l1_gradient(const SliceGrid& grid, const Gmm& gmm, const L1Value& v,
                                const std::vector<double>& rgb_amp = {});

struct RefineSettings {
  int evaluations = 150;  // objective evaluations per problem (device calls), at most
  double kl = 5.0;       // weight of the Kullback-Leibler divergence beside the L1 error
  double rgb = 0;        // the channels' share of the L1 error (a set with rgb), below 1; 0: the luminance alone
};

// Refines every query's mixture (same K) toward the least objective, starting
// from it. Covariances stay at or above (half the smaller cell step)^2 (narrower
// components are widened to it first): the table does not resolve narrower ones, and the
// stand-in is compared by its density at the cell centers. Returns one mixture per
// query: the best point the walk reached (the start when nothing was better).
std::vector<Gmm> refine_l1(const L1Evaluator& evaluate, const SliceSet& set, const std::vector<L1Query>& start,
                           const RefineSettings& settings);

}  // namespace bsdfmix
