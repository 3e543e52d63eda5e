// The narrowest lobe of a measured RGL BRDF and the grid that resolves it (docs/rgl.md,
// "Resolving sharp lobes"): `bsdfmix import rgl --resolve`.
#pragma once

#include <cstddef>
#include <vector>

namespace bsdfmix {

class RglBrdf;

// The peak of f cos(theta_i) (luminance) for one view elevation and its full widths at
// half maximum through the peak: along theta_i, and across it (the great circle through
// the peak along the azimuthal direction). Radians.
struct RglLobe {
  double theta_o = 0, theta_i = 0, phi_i = 0, peak = 0;
  double fwhm_theta = 0, fwhm_phi = 0;
};

// The lobe at `views` view elevations (cell centers of [0, pi/2]), each found on a
// 0.5 x 1 degree scan of the hemisphere and measured on a 0.01 degree line through its
// peak. A width that does not fall to half within kLobeReach of the peak is kLobeReach x 2.
constexpr double kLobeReach = 0.35;
std::vector<RglLobe> rgl_lobes(const RglBrdf& brdf, int views = 18);

// The rule: at least kCellsPerLobe cells across every lobe's half-maximum width, in
// theta_i and in phi_i (on its arc), and theta_o slices no farther apart than half the
// narrowest width (a mirror lobe moves as far as the view does); never below the floors,
// never above the caps.
constexpr double kCellsPerLobe = 3.0;
struct RglGrid {
  std::size_t n_theta_o = 0, n_theta_i = 0, n_phi_i = 0;
  RglLobe narrowest;  // the lobe of the smallest width, theta or phi
};
RglGrid rgl_resolving_grid(const std::vector<RglLobe>& lobes, std::size_t floor_theta_o, std::size_t floor_theta_i,
                           std::size_t floor_phi_i, std::size_t cap_theta = 720, std::size_t cap_phi = 1440);

}  // namespace bsdfmix
