// Relative L1 error of a slice mixture, and pooled slices.
#include "sweep/fit_error.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/domain.hpp"
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

// A Gaussian's mean density over a dtheta x dphi cell centered at (theta, phi): its density
// at the center, or, narrower than half a cell (sub_cell: the table cannot resolve it), its
// mean over 3 x 3 points of the cell (offsets -1/3, 0, 1/3 of a step).
double cell_density(const mix::Gaussian& g, bool narrow, Map map, double theta, double phi, double dt, double dp) {
  auto at = [&](double t, double p) {
    if (map != Map::ThetaPhi) mix::to_map(map, t, p, t, p);
    return g.density(t, p);
  };
  if (!narrow) return at(theta, phi);
  double sub = 0;
  for (int a = -1; a <= 1; ++a)
    for (int b = -1; b <= 1; ++b) sub += at(theta + a * dt / 3, wrap_phi(phi + b * dp / 3));
  return sub / 9;
}

// The Lambertian base's density at the cell centered at (theta, phi), at the cell's point
// of the mixture's map (include/bsdfmix/mixture.hpp lambert_base); 0 without a base.
double base_density(const mix::SliceMixture& m, double theta, double phi) {
  if (!(m.base > 0)) return 0;
  double x, y;
  mix::to_map(m.map, theta, phi, x, y);
  return mix::lambert_base(x, y);
}

}  // namespace

double l1_rel_error(const WeightedSlice& s, const mix::SliceMixture& m) {
  const double total = s.total();
  if (!(total > 0)) return 0.0;
  const double dt = axis_step(s.theta), dp = axis_step(s.phi), area = dt * dp;
  // A component narrower than half a cell (the table cannot resolve it: EM leaves it at
  // its covariance floor, a quarter cell) is integrated over each cell (3 x 3 points);
  // a wider one is compared like the table, by its density at the cell centers.
  std::vector<const mix::Gaussian*> broad, narrow;
  // On an equal-area map every component is compared at the cell centers, as a renderer's
  // quadrature (and bsdfmix compare) sees it: the cells' sizes in the plane vary.
  const bool averaged = s.map == Map::ThetaPhi;
  for (const auto& g : m.components)
    (averaged && sub_cell(g.s_tt, g.s_tp, g.s_pp, dt, dp) ? narrow : broad).push_back(&g);
  const std::size_t np = s.phi.size();
  double err = 0;
  for (std::size_t t = 0; t < s.theta.size(); ++t) {
    const double cell = area * mix::map_jacobian(s.map, s.theta[t]);  // in the mixture's plane
    for (std::size_t p = 0; p < np; ++p) {
      double density = 0;
      for (const auto* g : broad) density += g->weight * cell_density(*g, false, s.map, s.theta[t], s.phi[p], dt, dp);
      for (const auto* g : narrow) density += g->weight * cell_density(*g, true, s.map, s.theta[t], s.phi[p], dt, dp);
      err += std::abs(s.w[t * np + p] - total * density * cell);
    }
  }
  return (err + s.extra_error) / (s.reference_total > 0 ? s.reference_total : total);
}

std::vector<double> cell_masses(const WeightedSlice& s, const mix::SliceMixture& m) {
  const std::size_t nt = s.theta.size(), np = s.phi.size();
  const double dt = axis_step(s.theta), dp = axis_step(s.phi), area = dt * dp;
  const bool averaged = s.map == Map::ThetaPhi;  // as l1_rel_error
  std::vector<bool> narrow;
  for (const auto& g : m.components) narrow.push_back(averaged && sub_cell(g.s_tt, g.s_tp, g.s_pp, dt, dp));
  std::vector<double> out(nt * np, 0.0);
  for (std::size_t t = 0; t < nt; ++t) {
    const double cell = area * mix::map_jacobian(s.map, s.theta[t]);
    for (std::size_t p = 0; p < np; ++p) {
      out[t * np + p] += m.base * base_density(m, s.theta[t], s.phi[p]) * cell;
      for (std::size_t k = 0; k < m.components.size(); ++k) {
        const mix::Gaussian& g = m.components[k];
        out[t * np + p] += g.weight * cell_density(g, narrow[k], s.map, s.theta[t], s.phi[p], dt, dp) * cell;
      }
    }
  }
  return out;
}

StandInError stand_in_error(const WeightedSlice& s, const std::vector<double>& rgb, const mix::SliceMixture& m) {
  StandInError e;
  const std::size_t nt = s.theta.size(), np = s.phi.size(), n = nt * np;
  const double dt = axis_step(s.theta), dp = axis_step(s.phi), area = dt * dp;
  const bool colour = !rgb.empty();
  // A Gaussian's mass in a cell: its mean density there, by the header, times the area.
  auto mass = [&](const mix::Gaussian& g, bool narrow, double theta, double phi) {
    return cell_density(g, narrow, s.map, theta, phi, dt, dp) * area * mix::map_jacobian(s.map, theta);
  };
  std::vector<bool> narrow, narrow_colour;
  const bool averaged = s.map == Map::ThetaPhi;  // as l1_rel_error
  for (const auto& g : m.components) narrow.push_back(averaged && sub_cell(g.s_tt, g.s_tp, g.s_pp, dt, dp));
  for (const auto& g : m.colour) narrow_colour.push_back(averaged && sub_cell(g.s_tt, g.s_tp, g.s_pp, dt, dp));
  // Each component's mass in a cell (its density there, by the header, times the area),
  // its luminance amplitude scale * weight and, with colour, its rgb amplitudes.
  double lum = 0, lum_err = 0, abs_rgb = 0, rgb_err = 0, neg_err = 0;
  for (std::size_t t = 0; t < nt; ++t)
    for (std::size_t p = 0; p < np; ++p) {
      const std::size_t i = t * np + p;
      double y = 0, c[3] = {0, 0, 0};
      if (m.base > 0) {  // the Lambertian base's mass in the cell
        const double d = base_density(m, s.theta[t], s.phi[p]) * area * mix::map_jacobian(s.map, s.theta[t]);
        y += m.scale * m.base * d;
        for (int q = 0; q < 3; ++q) c[q] += (m.has_rgb ? m.base_rgb[q] : m.scale * m.base) * d;
      }
      for (std::size_t k = 0; k < m.components.size(); ++k) {
        const mix::Gaussian& g = m.components[k];
        const double d = mass(g, narrow[k], s.theta[t], s.phi[p]);
        y += m.scale * g.weight * d;
        if (m.colour.empty())
          for (int q = 0; q < 3; ++q) c[q] += (m.has_rgb ? g.rgb[q] : m.scale * g.weight) * d;
      }
      if (colour)
        for (std::size_t k = 0; k < m.colour.size(); ++k) {
          const double d = mass(m.colour[k], narrow_colour[k], s.theta[t], s.phi[p]);
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
