// Which slices a sweep fits.
#include "sweep/slice_plan.hpp"

#include <set>

#include "core/domain.hpp"

namespace bsdfmix {

namespace {

// The axis cells around x (bracket: clamped at the ends, periodic axes wrap); one cell
// when x is at its center, to rounding (an axis value written out and read back lands a
// few ulps to either side of it).
std::vector<std::size_t> around(const std::vector<double>& axis, double x, bool periodic) {
  const Bracket b = bracket(axis, x, periodic);
  constexpr double kAt = 1e-9;  // of a cell
  if (b.i1 == b.i0 || b.f < kAt) return {b.i0};
  if (b.f > 1 - kAt) return {b.i1};
  return {b.i0, b.i1};
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
