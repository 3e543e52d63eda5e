// Which slices a sweep fits.
#include "sweep/slice_plan.hpp"

#include <algorithm>
#include <set>
#include <string>

#include "core/domain.hpp"
#include "core/error.hpp"

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

std::vector<std::size_t> stride_rows(std::size_t n, std::size_t stride) {
  std::vector<std::size_t> rows;
  for (std::size_t r = 0; r < n; r += std::max<std::size_t>(stride, 1)) rows.push_back(r);
  if (n > 0 && rows.back() != n - 1) rows.push_back(n - 1);
  return rows;
}

std::vector<std::size_t> chosen_rows(const std::vector<double>& axis, const FitSettings& fit) {
  std::set<std::size_t> rows;
  if (fit.theta_o_stride > 0)
    for (std::size_t r : stride_rows(axis.size(), std::size_t(fit.theta_o_stride))) rows.insert(r);
  for (int r : fit.theta_o_rows) {
    if (r < 0 || std::size_t(r) >= axis.size())
      throw InputError("fit.theta_o_rows: row " + std::to_string(r) + " is past the table's " +
                       std::to_string(axis.size()) + " theta_o rows (0 to " + std::to_string(axis.size() - 1) + ")");
    rows.insert(std::size_t(r));
  }
  for (double d : fit.theta_o_deg) rows.insert(nearest_center(axis, d * kPi / 180));
  return {rows.begin(), rows.end()};
}

std::vector<SliceRef> plan_fit_slices(const TableMeta& meta, const FitSettings& fit) {
  const std::vector<std::size_t> rows = chosen_rows(meta.theta_o, fit);
  if (rows.empty()) return plan_slices(meta, fit.theta_o, fit.phi_o);
  const std::size_t np = meta.phi_o.size();
  std::set<std::size_t> chosen;
  for (std::size_t t : rows)
    for (std::size_t p = 0; p < np; ++p) chosen.insert(t * np + p);
  if (!fit.theta_o.empty())
    for (const SliceRef& r : plan_slices(meta, fit.theta_o, fit.phi_o)) chosen.insert(r.index);
  std::vector<SliceRef> out;
  for (std::size_t s : chosen) out.push_back({s, s / np, s % np});
  return out;
}

}  // namespace bsdfmix
