// Which slices a sweep fits.
#include "sweep/slice_plan.hpp"

#include <algorithm>
#include <cmath>
#include <set>

namespace bsdfmix {

namespace {

// The axis cells around x (clamped at the ends; periodic axes wrap).
std::vector<std::size_t> around(const std::vector<double>& axis, double x, bool periodic) {
  const std::size_t n = axis.size();
  if (n == 1) return {0};
  const double step = axis_step(axis);
  double u = (x - axis.front()) / step;
  if (periodic) {
    u = std::fmod(u, double(n));
    if (u < 0) u += double(n);
    const std::size_t i0 = std::min(static_cast<std::size_t>(u), n - 1);
    return {i0, (i0 + 1) % n};
  }
  if (u <= 0) return {0};
  if (u >= double(n - 1)) return {n - 1};
  const std::size_t i0 = static_cast<std::size_t>(u);
  if (u == double(i0)) return {i0};
  return {i0, i0 + 1};
}

}  // namespace

std::vector<SliceRef> plan_slices(const TableMeta& meta, const std::vector<double>& theta_o,
                                  const std::vector<double>& phi_o) {
  const std::size_t np = meta.phi_o.size();
  std::set<std::size_t> chosen;
  if (theta_o.empty()) {
    for (std::size_t s = 0; s < meta.n_slices(); ++s) chosen.insert(s);
  } else {
    const std::vector<double> phis = (meta.azimuthal || phi_o.empty()) ? std::vector<double>{0.0} : phi_o;
    for (double t : theta_o)
      for (double p : phis)
        for (std::size_t ti : around(meta.theta_o, t, false))
          for (std::size_t pi : meta.azimuthal ? std::vector<std::size_t>{0} : around(meta.phi_o, wrap_phi(p), true))
            chosen.insert(ti * np + pi);
  }
  std::vector<SliceRef> out;
  for (std::size_t s : chosen) out.push_back({s, s / np, s % np});
  return out;
}

}  // namespace bsdfmix
