// The uniform share each fitted slice earns on its own table cells.
#include "sweep/earned_share.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace bsdfmix {

double max_weight(const WeightedSlice& s, const std::vector<double>& masses, const std::vector<double>& uniform,
                  double share) {
  const double total = s.total();
  if (!(total > 0)) return 0.0;
  double worst = 0;
  for (std::size_t i = 0; i < s.w.size(); ++i) {
    if (!(s.w[i] > 0)) continue;
    const double q = (1 - share) * masses[i] + share * uniform[i];
    if (!(q > 0)) return std::numeric_limits<double>::infinity();
    worst = std::max(worst, s.w[i] / q);
  }
  return worst / total;
}

std::vector<double> uniform_masses(const WeightedSlice& s, Domain d) {
  const std::size_t nt = s.theta.size(), np = s.phi.size();
  const double cell = axis_step(s.theta) * axis_step(s.phi) * (d == Domain::Hemisphere ? 1 / (2 * kPi) : 1 / (4 * kPi));
  std::vector<double> out(nt * np);
  for (std::size_t t = 0; t < nt; ++t) std::fill_n(out.begin() + long(t * np), np, cell * jacobian(d, s.theta[t]));
  return out;
}

EarnedShare earned_share(const WeightedSlice& s, const mix::SliceMixture& m, Domain d) {
  const std::vector<double> masses = cell_masses(s, m), uniform = uniform_masses(s, d);
  const double fixed = max_weight(s, masses, uniform, kShareLadder.back());
  if (!std::isfinite(fixed)) return {kShareLadder.back(), fixed};  // even 0.1 leaves a cell unsampled
  const double bound = std::max(fixed, kWeightCap);
  for (std::size_t i = 0; i + 1 < kShareLadder.size(); ++i) {
    const double w = max_weight(s, masses, uniform, kShareLadder[i]);
    if (w <= bound) return {kShareLadder[i], w};
  }
  return {kShareLadder.back(), fixed};  // 0.1 itself: W(0.1) <= bound, taken once above
}

}  // namespace bsdfmix
