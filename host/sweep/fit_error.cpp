// Relative L1 error of a slice mixture, and pooled slices.
#include "sweep/fit_error.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/domain.hpp"
#include "core/vector_math.hpp"
#include "fit/gmm.hpp"

namespace bsdfmix {

double WeightedSlice::total() const {
  double t = 0;
  for (double x : w) t += x;
  return t;
}

WeightedSlice pool_slice(const WeightedSlice& s, std::size_t f) {
  const std::size_t nt = s.theta.size(), np = s.phi.size();
  if (f <= 1 || nt % f != 0 || np % f != 0) return s;
  WeightedSlice out;
  out.map = s.map;
  out.reference_total = s.reference_total;
  out.extra_error = s.extra_error;
  for (std::size_t t = 0; t < nt; t += f) {
    double c = 0;
    for (std::size_t k = 0; k < f; ++k) c += s.theta[t + k];
    out.theta.push_back(c / double(f));
  }
  for (std::size_t p = 0; p < np; p += f) {
    double c = 0;
    for (std::size_t k = 0; k < f; ++k) c += s.phi[p + k];
    out.phi.push_back(c / double(f));
  }
  const std::size_t mt = nt / f, mp = np / f;
  out.w.assign(mt * mp, 0.0);
  for (std::size_t t = 0; t < nt; ++t)
    for (std::size_t p = 0; p < np; ++p) out.w[(t / f) * mp + p / f] += s.w[t * np + p];
  return out;
}

namespace {

// The cells of one row of a slice as the mixture's map sees them, and each component's
// mean density over them: its density at the cell's point, or, narrower than half a cell
// (sub_cell: the table cannot resolve it), its mean over 3 x 3 points of the cell
// (offsets -1/3, 0, 1/3 of a step). The header's Gaussian::density, a row at a time: its
// exps through exp_in_place (vectorized, within 4 ulp of std::exp), its sums in the
// header's order.
class RowDensities {
 public:
  explicit RowDensities(const WeightedSlice& s) : s_(s), np_(s.phi.size()), dt_(axis_step(s.theta)), dp_(axis_step(s.phi)) {
    for (auto* v : {&x_, &y_, &arg_, &sum_, &sub_t_, &sub_}) v->resize(np_);
    for (int b = 0; b < 3; ++b) {
      sub_phi_[b].resize(np_);
      for (std::size_t p = 0; p < np_; ++p) sub_phi_[b][p] = wrap_phi(s.phi[p] + (b - 1) * dp_ / 3);
    }
  }

  // Row t's cell points in the map (once per row, for every component).
  void set_row(std::size_t t) {
    theta_ = s_.theta[t];
    for (std::size_t p = 0; p < np_; ++p) mix::to_map(s_.map, theta_, s_.phi[p], x_[p], y_[p]);
  }

  // g's mean density over each cell of the row, into out[0 .. np).
  void density(const mix::Gaussian& g, bool narrow, double* out) {
    if (!narrow) {
      at(g, x_.data(), y_.data(), out);
      return;
    }
    // Only on the (theta, phi) map (as l1_rel_error decides): the sub-points are angles.
    std::fill(out, out + np_, 0.0);
    for (int a = -1; a <= 1; ++a) {
      std::fill(sub_t_.begin(), sub_t_.end(), theta_ + a * dt_ / 3);
      for (int b = 0; b < 3; ++b) {
        at(g, sub_t_.data(), sub_phi_[b].data(), sub_.data());
        for (std::size_t p = 0; p < np_; ++p) out[p] += sub_[p];
      }
    }
    for (std::size_t p = 0; p < np_; ++p) out[p] /= 9;
  }

 private:
  // The header's density at the points (x[p], y[p]), summed over g's phi images.
  void at(const mix::Gaussian& g, const double* x, const double* y, double* out) {
    std::fill(sum_.begin(), sum_.end(), 0.0);
    const double mt = g.mu_t, mp = g.mu_p, cut = g.cut, a = g.i_tt, b = g.i_tp, c = g.i_pp;
    double* arg = arg_.data();
    for (int m = -g.images; m <= g.images; ++m) {
      if (!any_near(y, m, mp, cut)) continue;  // an image past the cut at every cell adds nothing
      for (std::size_t p = 0; p < np_; ++p) {
        const double dt = x[p] - mt;
        const double dp = y[p] + 2 * kPi * m - mp;
        const double q = a * dt * dt + 2 * b * dt * dp + c * dp * dp;
        // as the header: images past the cut and exps below ~1e-326 add nothing
        const bool far = (std::abs(dp) > cut) | !(q < 1500);
        arg[p] = far ? -1e300 : -0.5 * q;
      }
      exp_in_place(arg, np_);
      for (std::size_t p = 0; p < np_; ++p) sum_[p] += arg[p];
    }
    for (std::size_t p = 0; p < np_; ++p) out[p] = g.norm * sum_[p];
  }

  // Whether image m of a component at phi mp is within its cut at some point y[p] (dp as
  // at() takes it).
  bool any_near(const double* y, int m, double mp, double cut) const {
    double n = 0;  // a double count: the loop vectorizes
    for (std::size_t p = 0; p < np_; ++p) n += std::abs(y[p] + 2 * kPi * m - mp) <= cut ? 1.0 : 0.0;
    return n > 0;
  }

  const WeightedSlice& s_;
  std::size_t np_;
  double dt_, dp_, theta_ = 0;
  std::vector<double> x_, y_, arg_, sum_, sub_t_, sub_;  // the row's points; scratch
  std::vector<double> sub_phi_[3];                      // the 3 sub-point phis of each cell
};

// The Lambertian base's density at the cell centered at (theta, phi), at the cell's point
// of the mixture's map (include/bsdfmix/mixture.hpp lambert_base); 0 without a base.
double base_density(const mix::SliceMixture& m, double theta, double phi) {
  if (!(m.base > 0)) return 0;
  double x, y;
  mix::to_map(m.map, theta, phi, x, y);
  return mix::lambert_base(x, y);
}

// Which components are compared by their mean over 3 x 3 points of a cell: narrower than
// half a cell, on the (theta, phi) map only. On an equal-area map every component is
// compared at the cell centers, as a renderer's quadrature (and bsdfmix compare) sees it:
// the cells' sizes in the plane vary.
std::vector<bool> narrow_components(const WeightedSlice& s, const std::vector<mix::Gaussian>& gs) {
  const double dt = axis_step(s.theta), dp = axis_step(s.phi);
  std::vector<bool> out;
  for (const auto& g : gs) out.push_back(s.map == Map::ThetaPhi && sub_cell(g.s_tt, g.s_tp, g.s_pp, dt, dp));
  return out;
}

}  // namespace

double l1_rel_error(const WeightedSlice& s, const mix::SliceMixture& m) {
  const double total = s.total();
  if (!(total > 0)) return 0.0;
  const double area = axis_step(s.theta) * axis_step(s.phi);
  // A component narrower than half a cell (the table cannot resolve it: EM leaves it at
  // its covariance floor, a quarter cell) is integrated over each cell (3 x 3 points);
  // a wider one is compared like the table, by its density at the cell centers. The
  // broad ones are summed first, then the narrow ones.
  const std::vector<bool> narrow = narrow_components(s, m.components);
  std::vector<std::size_t> order;
  for (int pass = 0; pass < 2; ++pass)
    for (std::size_t k = 0; k < m.components.size(); ++k)
      if (narrow[k] == (pass == 1)) order.push_back(k);
  const std::size_t np = s.phi.size();
  RowDensities rows(s);
  std::vector<double> density(np), d(np);
  double err = 0;
  for (std::size_t t = 0; t < s.theta.size(); ++t) {
    const double cell = area * mix::map_jacobian(s.map, s.theta[t]);  // in the mixture's plane
    rows.set_row(t);
    std::fill(density.begin(), density.end(), 0.0);
    for (std::size_t k : order) {
      const mix::Gaussian& g = m.components[k];
      rows.density(g, narrow[k], d.data());
      for (std::size_t p = 0; p < np; ++p) density[p] += g.weight * d[p];
    }
    for (std::size_t p = 0; p < np; ++p) err += std::abs(s.w[t * np + p] - total * density[p] * cell);
  }
  return (err + s.extra_error) / (s.reference_total > 0 ? s.reference_total : total);
}

std::vector<double> cell_masses(const WeightedSlice& s, const mix::SliceMixture& m) {
  const std::size_t nt = s.theta.size(), np = s.phi.size();
  const double area = axis_step(s.theta) * axis_step(s.phi);
  const std::vector<bool> narrow = narrow_components(s, m.components);  // as l1_rel_error
  std::vector<double> out(nt * np, 0.0), d(np);
  RowDensities rows(s);
  for (std::size_t t = 0; t < nt; ++t) {
    const double cell = area * mix::map_jacobian(s.map, s.theta[t]);
    double* o = out.data() + t * np;
    for (std::size_t p = 0; p < np; ++p) o[p] += m.base * base_density(m, s.theta[t], s.phi[p]) * cell;
    rows.set_row(t);
    for (std::size_t k = 0; k < m.components.size(); ++k) {
      const mix::Gaussian& g = m.components[k];
      rows.density(g, narrow[k], d.data());
      for (std::size_t p = 0; p < np; ++p) o[p] += g.weight * d[p] * cell;
    }
  }
  return out;
}

StandInError stand_in_error(const WeightedSlice& s, const std::vector<double>& rgb, const mix::SliceMixture& m) {
  StandInError e;
  const std::size_t nt = s.theta.size(), np = s.phi.size(), n = nt * np;
  const double area = axis_step(s.theta) * axis_step(s.phi);
  const bool colour = !rgb.empty();
  const std::vector<bool> narrow = narrow_components(s, m.components);  // as l1_rel_error
  const std::vector<bool> narrow_colour = narrow_components(s, m.colour);
  const std::size_t K = m.components.size(), C = colour ? m.colour.size() : 0;
  // Per row: each component's and colour copy's mass in each cell (its density there, by
  // the header's formula, times the area), mass[k np + p], colour copies after the components.
  std::vector<double> mass((K + C) * np);
  RowDensities rows(s);
  double lum = 0, lum_err = 0, abs_rgb = 0, rgb_err = 0, neg_err = 0;
  for (std::size_t t = 0; t < nt; ++t) {
    const double jac = mix::map_jacobian(s.map, s.theta[t]);
    rows.set_row(t);
    for (std::size_t k = 0; k < K + C; ++k) {
      double* d = mass.data() + k * np;
      rows.density(k < K ? m.components[k] : m.colour[k - K], k < K ? narrow[k] : narrow_colour[k - K], d);
      for (std::size_t p = 0; p < np; ++p) d[p] = d[p] * area * jac;
    }
    for (std::size_t p = 0; p < np; ++p) {
      const std::size_t i = t * np + p;
      double y = 0, c[3] = {0, 0, 0};
      if (m.base > 0) {  // the Lambertian base's mass in the cell
        const double d = base_density(m, s.theta[t], s.phi[p]) * area * jac;
        y += m.scale * m.base * d;
        for (int q = 0; q < 3; ++q) c[q] += (m.has_rgb ? m.base_rgb[q] : m.scale * m.base) * d;
      }
      for (std::size_t k = 0; k < K; ++k) {
        const mix::Gaussian& g = m.components[k];
        const double d = mass[k * np + p];
        y += m.scale * g.weight * d;
        if (m.colour.empty())
          for (int q = 0; q < 3; ++q) c[q] += (m.has_rgb ? g.rgb[q] : m.scale * g.weight) * d;
      }
      for (std::size_t k = 0; k < C; ++k) {
        const double d = mass[(K + k) * np + p];
        for (int q = 0; q < 3; ++q) c[q] += m.colour[k].rgb[q] * d;
      }
      lum += s.w[i];
      lum_err += std::abs(s.w[i] - y);
      if (!colour) continue;
      for (std::size_t ch = 0; ch < 3; ++ch) {
        const double w = rgb[ch * n + i], d = std::abs(w - c[ch]);
        abs_rgb += std::abs(w);
        rgb_err += d;
        if (w < 0) neg_err += d;
      }
    }
  }
  e.l1_rel = lum > 0 ? lum_err / lum : 0.0;
  if (!colour) {
    e.rgb_l1_rel = e.rgb_negative = std::numeric_limits<double>::quiet_NaN();
  } else if (abs_rgb > 0) {
    e.rgb_l1_rel = rgb_err / abs_rgb;
    e.rgb_negative = neg_err / abs_rgb;
  }
  return e;
}

}  // namespace bsdfmix
