// Channel amplitudes of fixed Gaussians: per slice and component, the non-negative
// amplitude of each channel (the luminance; R, G, B with colour) that makes the Gaussians,
// kept as they were fitted, the closest stand-in for that channel over the slice's cells.
// The cells are the domain, so mass a Gaussian leaks past the theta border is made up by
// the amplitudes rather than lost, and each channel's integral is kept: the stand-in's
// in-domain integral (the components' closed-form in-domain masses times their
// amplitudes) equals the channel's sum over the cells. A channel that is measurement noise
// around zero (is_noise: its negative cells hold more than kNoiseShare of its absolute sum,
// so its sum is uncertain by more than that) has no integral to keep: its amplitudes are
// its least-L1 fit alone. docs/fitting.md, "Colour and energy".
//
// The objective is the L1 error of each channel, by iteratively reweighted least squares:
// the first solve weighs every cell 1, every later one weighs cell i by
// 1 / max(|r_i|, delta) at the residuals r of the amplitudes before; each solve is a
// non-negative least squares of the normal equations with the integral as a constraint,
// on the host (nnls_normal). The normal equations are sums over the cells of every problem
// of a batch: EmEngine::amplitude_sums (kernels/em.cl amp_basis and amp_sums) or, in
// double, amplitude_sums_reference.
#pragma once

#include <cstddef>
#include <functional>
#include <vector>

#include "core/domain.hpp"
#include "fit/gmm.hpp"
#include "fit/slices.hpp"

namespace bsdfmix {

// The channels of each slice on one grid: per slice, `channels` rows of the grid's cells
// (channel-major, row-major [theta][phi] within a channel), integrand weights of any sign
// (measured channels dip below zero where they are noise).
constexpr int kMaxChannels = 4;
struct ChannelSet {
  SliceGrid grid;
  int channels = 1;  // 1 .. kMaxChannels
  std::vector<std::vector<double>> values;
};

// One evaluation: fixed Gaussians on one slice, the amplitudes to take the residuals at,
// and per channel the reweighting floor delta (<= 0: every cell weighs 1).
struct AmplitudeQuery {
  std::size_t slice = 0;
  Gmm gmm;                    // shapes only: the weights are not used
  std::vector<double> amp;    // channels x K, channel-major
  std::vector<double> delta;  // channels
};

// Per channel c, with phi_j the mass of component j in the cell (area * N_j at the cell
// center, or N_j's mean over 3 x 3 points of the cell for a component narrower than half a
// cell, gmm.hpp sub_cell; every phi image within 6 standard deviations, l1_images),
// r = w_c - sum_j amp[c][j] phi_j and d = 1 / max(|r|, delta_c):
// gram[(c K + i) K + j] = sum d phi_i phi_j, rhs[c K + i] = sum d w_c phi_i, l1[c] = sum |r|.
struct AmplitudeSums {
  std::vector<double> gram, rhs, l1;
};

std::vector<AmplitudeSums> amplitude_sums_reference(const ChannelSet& set, const std::vector<AmplitudeQuery>& queries);

using AmplitudeEvaluator = std::function<std::vector<AmplitudeSums>(const std::vector<AmplitudeQuery>&)>;

struct AmplitudeSettings {
  int iterations = 12;  // reweighted solves after the first, unweighted one
  double delta = 1e-2;  // the reweighting floor, relative to the channel's mean |w| over the cells
};

// A problem: the Gaussians of one slice of the set.
struct AmplitudeProblem {
  std::size_t slice = 0;
  Gmm gmm;
};

struct AmplitudeFit {
  std::vector<double> amp;  // channels x K, channel-major
  std::vector<double> l1;   // channels: sum |r| over the cells at amp
};

// Fits every problem's amplitudes, all problems of a call evaluated together (one
// `evaluate` per iteration); keeps, per problem and channel, the iterate of least L1
// error. A problem stops once its L1 error summed over the channels no longer falls.
std::vector<AmplitudeFit> fit_amplitudes(const AmplitudeEvaluator& evaluate, const ChannelSet& set,
                                         const std::vector<AmplitudeProblem>& problems,
                                         const AmplitudeSettings& settings = {});

// A channel whose negative cells hold more than this share of its absolute sum is noise
// around zero: its integral is not kept.
constexpr double kNoiseShare = 0.005;
bool is_noise(double negative, double abs_sum);

// The mass of component j of g inside the domain of grid's plane: on ThetaPhi and the
// cylinder the first axis within its range ([lo, hi]: the domain's theta range, or
// [-1, 1]) and the second over one period (all of it),
// 1/2 (erf((hi - mu) / (sqrt 2 sigma)) - erf((lo - mu) / (sqrt 2 sigma))); on the disk the
// mass within radius sqrt(2), by the grid's cells.
double in_domain_mass(const SliceGrid& grid, const Gmm& g, int j);
// The same on ThetaPhi: theta within the domain's range.
double in_domain_mass(Domain d, double mu_t, double s_tt);

// argmin over a >= 0 of 1/2 a^T G a - b^T a for a symmetric positive (semi)definite K x K
// G (row-major): Lawson and Hanson's active set, on the normal equations.
std::vector<double> nnls_normal(const std::vector<double>& G, const std::vector<double>& b, int K);

// The amplitudes of one channel from its normal equations, under the constraint z . a = W
// (z the components' in-domain masses, W the channel's integral; exact after the solve).
// All zero when W <= 0; W NaN: no constraint (a noisy channel).
std::vector<double> solve_channel(const std::vector<double>& G, const std::vector<double>& b,
                                  const std::vector<double>& z, double W, int K);

}  // namespace bsdfmix
