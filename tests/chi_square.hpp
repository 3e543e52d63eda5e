// Pearson's chi-square test of observed bin counts against expected ones, shared by the
// sampler tests: bins expecting fewer than 5 samples are pooled into one (as Mitsuba's
// chi2 test), and the p-value is the regularized upper incomplete gamma function of
// Boost.Math.
#pragma once

#include <boost/math/special_functions/gamma.hpp>

#include <cstddef>
#include <vector>

namespace bsdfmix::test {

struct ChiSquare {
  double stat = 0, p = 0;
  int dof = 0;
};

inline ChiSquare pearson(const std::vector<double>& observed, const std::vector<double>& expected) {
  ChiSquare r;
  double pooled_o = 0, pooled_e = 0;
  int bins = 0;
  for (std::size_t k = 0; k < observed.size(); ++k) {
    if (expected[k] < 5) {
      pooled_o += observed[k];
      pooled_e += expected[k];
      continue;
    }
    r.stat += (observed[k] - expected[k]) * (observed[k] - expected[k]) / expected[k];
    ++bins;
  }
  if (pooled_e > 5) {
    r.stat += (pooled_o - pooled_e) * (pooled_o - pooled_e) / pooled_e;
    ++bins;
  }
  r.dof = bins - 1;
  r.p = r.dof > 0 ? boost::math::gamma_q(0.5 * r.dof, 0.5 * r.stat) : 0.0;
  return r;
}

}  // namespace bsdfmix::test
