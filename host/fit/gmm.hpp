// A 2D Gaussian mixture over (theta, phi), phi periodic, and its density.
#pragma once

#include <vector>

namespace bsdfmix {

struct Gmm {
  std::vector<double> weight;  // K, summing to 1
  std::vector<double> mean;    // 2K: theta, phi (phi wrapped into [-pi, pi))
  std::vector<double> cov;     // 3K: s_tt, s_tp, s_pp (rad^2)
  int k() const { return static_cast<int>(weight.size()); }
};

// The parameter-space density at (theta, phi): the sum over components and over
// the phi images phi + 2 pi m (m = -1, 0, 1) of the 2D normal densities.
double gmm_density(const Gmm& gmm, double theta, double phi);

// log of gmm_density, computed without underflow far from every component.
double gmm_log_density(const Gmm& gmm, double theta, double phi);

}  // namespace bsdfmix
