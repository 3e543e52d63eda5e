// The Lambertian base of a hemisphere slice fitted on the disk (docs/fitting.md, "The
// base"): the diffuse floor under the lobes, taken off the cells before the Gaussians are
// fitted, and added back as the mixture's closed-form base (include/bsdfmix/mixture.hpp).
#pragma once

#include <cstddef>
#include <vector>

namespace bsdfmix {

// The share of the cells, weighed by the base's own mass, whose f lies below the floor:
// the floor is this quantile of pi f over the hemisphere.
constexpr double kBaseQuantile = 0.02;

struct SliceBase {
  double lum = 0;             // the base's luminance amplitude: its integral, rho_d = pi f_floor
  double rgb[3] = {0, 0, 0};  // the same per channel (0 where the channel's floor is negative)
  double excess = 0;          // sum over cells of what the base puts above the luminance weights
};

// Estimates the base of one slice of integrand weights w (row-major [theta_i][phi_i] on the
// hemisphere, f cos J dtheta dphi) and takes it off: w_i -= b m_i, m_i = cos sin dtheta dphi / pi
// the base's mass in cell i, clamped at 0 (the clamped part is `excess`); with `rgb`
// (channel-major [3][cells]) each channel likewise, unclamped.
SliceBase take_base(const std::vector<double>& theta_i, std::size_t n_phi, double dtheta, double dphi,
                    std::vector<double>& w, std::vector<double>* rgb);

}  // namespace bsdfmix
