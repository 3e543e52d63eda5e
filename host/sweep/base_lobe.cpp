// The Lambertian base of a hemisphere slice.
#include "sweep/base_lobe.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

#include "core/domain.hpp"

namespace bsdfmix {

namespace {

// The kBaseQuantile quantile of w_i / m_i weighed by m_i (0 when every m_i is 0).
double floor_of(const double* w, const std::vector<double>& m) {
  std::vector<std::pair<double, double>> r;  // (ratio, weight)
  double total = 0;
  for (std::size_t i = 0; i < m.size(); ++i)
    if (m[i] > 0) {
      r.emplace_back(w[i] / m[i], m[i]);
      total += m[i];
    }
  if (!(total > 0)) return 0;
  std::sort(r.begin(), r.end());
  double acc = 0;
  for (const auto& [ratio, weight] : r) {
    acc += weight;
    if (acc >= kBaseQuantile * total) return std::max(ratio, 0.0);
  }
  return std::max(r.back().first, 0.0);
}

}  // namespace

SliceBase take_base(const std::vector<double>& theta_i, std::size_t n_phi, double dtheta, double dphi,
                    std::vector<double>& w, std::vector<double>* rgb) {
  const std::size_t n = w.size();
  std::vector<double> m(n);
  for (std::size_t i = 0; i < n; ++i) {
    const double t = theta_i[i / n_phi];
    m[i] = std::max(std::cos(t), 0.0) * std::sin(t) * dtheta * dphi / kPi;
  }
  SliceBase b;
  b.lum = floor_of(w.data(), m);
  for (std::size_t i = 0; i < n; ++i) {
    const double left = w[i] - b.lum * m[i];
    if (left < 0) b.excess -= left;
    w[i] = std::max(left, 0.0);
  }
  if (rgb && rgb->size() == 3 * n)
    for (int c = 0; c < 3; ++c) {
      double* ch = rgb->data() + std::size_t(c) * n;
      b.rgb[c] = floor_of(ch, m);
      for (std::size_t i = 0; i < n; ++i) ch[i] -= b.rgb[c] * m[i];
    }
  return b;
}

}  // namespace bsdfmix
