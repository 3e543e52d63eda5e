// A 2D Gaussian mixture over (theta, phi), phi periodic, and its density.
#pragma once

#include <cstddef>

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

// gmm_log_density at n points (theta[i], phi[i]) into out[i]: the same sums in the same
// order, the component constants taken once and the exps vectorized (core/vector_math.hpp:
// within 4 ulp of std::exp). For the evaluations over a slice's cells.
void gmm_log_densities(const Gmm& gmm, const double* theta, const double* phi, std::size_t n, double* out);

// Whether a component of covariance (s_tt, s_tp, s_pp) is narrower than half a cell of a
// dtheta x dphi grid (its smallest eigenvalue below (min(dtheta, dphi) / 2)^2): the table
// cannot resolve it, so its mass in a cell is its mean density over 3 x 3 points of the
// cell (offsets -1/3, 0, 1/3 of a step) times the cell area, where a wider one's is its
// density at the cell center times the area. The stand-in's cell masses follow this rule
// everywhere: the search's L1 error, the amplitude fit, the report (docs/formats.md).
bool sub_cell(double s_tt, double s_tp, double s_pp, double dtheta, double dphi);

}  // namespace bsdfmix
