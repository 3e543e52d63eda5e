// The one quantile and the one percent rounding of every summary.
#include "core/stats.hpp"

#include <algorithm>
#include <cmath>

#include "core/format.hpp"

namespace bsdfmix {

double quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const double h = std::clamp(q, 0.0, 1.0) * double(v.size() - 1);
  const std::size_t lo = std::size_t(std::floor(h)), hi = std::min(lo + 1, v.size() - 1);
  return v[lo] + (h - double(lo)) * (v[hi] - v[lo]);
}

std::string percent_text(double fraction) { return format_number(100 * fraction, "%.2f") + "%"; }

}  // namespace bsdfmix
