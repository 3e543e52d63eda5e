// The study's exact integrals by quadrature, and the tail-risk diagnostic.
#include "converge/quadrature.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace bsdfmix {

void gauss_legendre(int n, std::vector<double>& nodes, std::vector<double>& weights) {
  nodes.assign(std::size_t(n), 0.0);
  weights.assign(std::size_t(n), 0.0);
  for (int i = 0; i < n; ++i) {
    double x = std::cos(kPi * (i + 0.75) / (n + 0.5)), dp = 1;
    for (int it = 0; it < 100; ++it) {
      double p0 = 1, p1 = x;
      for (int k = 2; k <= n; ++k) {
        const double p2 = ((2 * k - 1) * x * p1 - (k - 1) * p0) / k;
        p0 = p1;
        p1 = p2;
      }
      if (n == 1) p0 = 1;
      dp = n * (x * p1 - p0) / (x * x - 1);
      const double dx = p1 / dp;
      x -= dx;
      if (std::abs(dx) < 1e-15) break;
    }
    nodes[std::size_t(i)] = x;
    weights[std::size_t(i)] = 2 / ((1 - x * x) * dp * dp);
  }
}

namespace {

double cos_factor(Domain d, double theta) { return d == Domain::Hemisphere ? std::cos(theta) : 1.0; }

// Sub-cell points per axis resolving features of size `feature` in cells of size `cell`.
int sub_points(double cell, double feature, int lo, int hi) {
  return std::clamp(int(std::ceil(3.0 * cell / std::max(feature, 1e-9))), lo, hi);
}

double smallest_sigma(const Problem& p) {
  double s = kPi;
  for (int k = 0; k < p.query.blend.count; ++k)
    for (const auto& g : p.set->slices[std::size_t(p.query.blend.slice[k])].components)
      s = std::min({s, std::sqrt(g.s_tt), std::sqrt(g.s_pp - g.s_tp * g.s_tp / g.s_tt)});
  return s;
}

// sum over cells (i, j) and n x n sub-cell nodes of fn(theta, phi_world) * c J dtheta dphi
template <class Fn>
double cell_quadrature(const TableSlice& t, int n, bool skip_zero_f, Fn fn) {
  std::vector<double> x, w;
  gauss_legendre(n, x, w);
  double total = 0;
  for (std::size_t i = 0; i < t.n_theta; ++i) {
    const double a = t.theta_edge(i), b = t.theta_edge(i + 1);
    if (!(b > a)) continue;
    std::vector<double> th(static_cast<std::size_t>(n)), wt(static_cast<std::size_t>(n));
    for (int k = 0; k < n; ++k) {
      th[std::size_t(k)] = 0.5 * (a + b) + 0.5 * (b - a) * x[std::size_t(k)];
      wt[std::size_t(k)] = 0.5 * (b - a) * w[std::size_t(k)] * cos_factor(t.domain, th[std::size_t(k)]) *
                           jacobian(t.domain, th[std::size_t(k)]);
    }
    for (std::size_t j = 0; j < t.n_phi; ++j) {
      const double fc = t.f[i * t.n_phi + j];
      if (skip_zero_f && fc == 0) continue;
      const double p0 = t.ph0 + t.dph * double(j) + t.rotate;
      double cell = 0;
      for (int kp = 0; kp < n; ++kp) {
        const double ph = wrap_phi(p0 + 0.5 * t.dph * (1 + x[std::size_t(kp)]));
        const double wp = 0.5 * t.dph * w[std::size_t(kp)];
        for (int kt = 0; kt < n; ++kt) cell += wt[std::size_t(kt)] * wp * fn(th[std::size_t(kt)], ph, fc);
      }
      total += cell;
    }
  }
  return total;
}

}  // namespace

double table_integral(const Problem& p) {
  const TableSlice& t = p.table;
  if (p.light.is_constant()) {
    double s = 0;
    for (std::size_t i = 0; i < t.n_theta; ++i) {
      double row = 0;
      for (std::size_t j = 0; j < t.n_phi; ++j) row += double(t.f[i * t.n_phi + j]);
      s += row * t.cell_weight(i);
    }
    return s * p.light.constant;
  }
  const int n = sub_points(std::max(t.dth, t.dph), p.light.finest_feature(), 6, 32);
  return cell_quadrature(t, n, true, [&](double th, double ph, double fc) { return fc * p.light.radiance(th, ph); });
}

double stand_in_integral(const Problem& p) {
  const mix::MixtureSet& set = *p.set;
  const Domain d = p.table.domain;
  if (p.light.is_constant() && set.map == mix::Map::ThetaPhi) {  // in closed form: normal CDFs in theta
    const double lo = theta_lo(d), hi = theta_hi(d);
    double s = 0;
    for (int k = 0; k < p.query.blend.count; ++k) {
      const mix::SliceMixture& sl = set.slices[std::size_t(p.query.blend.slice[k])];
      double mass = 0;
      for (const auto& g : sl.components) {
        const double sd = std::sqrt(g.s_tt) * std::sqrt(2.0);
        mass += g.weight * 0.5 * (std::erf((hi - g.mu_t) / sd) - std::erf((lo - g.mu_t) / sd));
      }
      s += p.query.blend.weight[k] * sl.scale * mass;
    }
    return s * p.light.constant;
  }
  // Over the whole domain (the stand-in also lives where the table's cells do not reach);
  // on an equal-area map always (its components and base are not normals in theta).
  TableSlice grid = p.table;
  const int n = sub_points(std::max(grid.dth, grid.dph), std::min(p.light.finest_feature(), smallest_sigma(p)), 6, 24);
  return cell_quadrature(grid, n, false, [&](double th, double ph, double) {
    const double cf = cos_factor(d, th);
    return cf > 0 ? set.eval_f(p.theta_o, p.phi_o, th, ph) * p.light.radiance(th, ph) : 0.0;
  });
}

TailDiagnostic tail_diagnostic(const Problem& p) {
  TailDiagnostic r;
  const TableSlice& t = p.table;
  const mix::MixtureSet& set = *p.set;
  const double pu = t.domain == Domain::Hemisphere ? 1 / (2 * kPi) : 1 / (4 * kPi);
  const int n = sub_points(std::max(t.dth, t.dph), smallest_sigma(p), 3, 12);
  std::vector<double> x, w;
  gauss_legendre(n, x, w);
  const double a = p.mis.uniform_fraction;
  double I = 0;
  for (std::size_t i = 0; i < t.n_theta; ++i)
    for (std::size_t j = 0; j < t.n_phi; ++j) I += double(t.f[i * t.n_phi + j]) * t.cell_weight(i);
  r.reference = I;
  Problem pc = p;
  pc.light = default_lighting(t.domain, 1.0);
  r.stand_in = stand_in_integral(pc);
  if (!(I > 0)) return r;
  double s_us = 0, s_is = 0, s_mis = 0;
  for (std::size_t i = 0; i < t.n_theta; ++i) {
    const double ta = t.theta_edge(i), tb = t.theta_edge(i + 1);
    for (std::size_t j = 0; j < t.n_phi; ++j) {
      const double W = double(t.f[i * t.n_phi + j]) * t.cell_weight(i) / I;
      if (!(W > 0)) continue;
      const double p0 = t.ph0 + t.dph * double(j) + t.rotate;
      double P = 0;  // mixture probability of the cell
      for (int kt = 0; kt < n; ++kt) {
        const double th = 0.5 * (ta + tb) + 0.5 * (tb - ta) * x[std::size_t(kt)];
        for (int kp = 0; kp < n; ++kp) {
          const double ph = wrap_phi(p0 + 0.5 * t.dph * (1 + x[std::size_t(kp)]));
          P += 0.25 * (tb - ta) * t.dph * w[std::size_t(kt)] * w[std::size_t(kp)] * set.pdf_param(p.theta_o, p.phi_o, th, ph);
        }
      }
      const double U = t.cell_solid_angle(i) * pu;
      const double M = a * U + (1 - a) * P;
      s_us += W * W / U;
      if (P > 0) {
        s_is += W * W / P;
        r.max_weight_is = std::max(r.max_weight_is, W / P);
      } else {
        r.missed_is += W;  // is_tab never samples this cell: bias, not variance
      }
      s_mis += W * W / M;
      r.max_weight_mis = std::max(r.max_weight_mis, W / M);
    }
  }
  r.relvar_us = s_us - 1;
  r.relvar_is = s_is - 1;
  r.relvar_mis = s_mis - 1;
  r.relvar_cdf = 0;
  return r;
}

}  // namespace bsdfmix

namespace bsdfmix {

// Per table cell where f > 0: W = the integral of L f c d(omega) over the cell and, for each
// of `k` densities, its integral over the cell (sub-cell Gauss-Legendre fine enough for the
// lighting); `pdfs(theta, phi, out)` writes the k densities at a point.
struct CellMasses {
  std::size_t k = 0;
  std::vector<double> W, P;  // [cell], [cell][k]
  double I = 0;              // the sum of W
};

template <class Pdfs>
CellMasses cell_masses(const Problem& p, std::size_t k, Pdfs pdfs) {
  const TableSlice& t = p.table;
  CellMasses cm;
  cm.k = k;
  const int n = sub_points(std::max(t.dth, t.dph), p.light.finest_feature(), 3, 8);
  std::vector<double> x, w, at(k);
  gauss_legendre(n, x, w);
  for (std::size_t i = 0; i < t.n_theta; ++i) {
    const double ta = t.theta_edge(i), tb = t.theta_edge(i + 1);
    if (!(tb > ta)) continue;
    for (std::size_t j = 0; j < t.n_phi; ++j) {
      const double fc = t.f[i * t.n_phi + j];
      if (!(fc > 0)) continue;
      const double p0 = t.ph0 + t.dph * double(j) + t.rotate;
      double wc = 0;
      const std::size_t base = cm.P.size();
      cm.P.resize(base + k, 0.0);
      for (int kt = 0; kt < n; ++kt) {
        const double th = 0.5 * (ta + tb) + 0.5 * (tb - ta) * x[std::size_t(kt)];
        const double jac = jacobian(t.domain, th), cf = cos_factor(t.domain, th);
        for (int kp = 0; kp < n; ++kp) {
          const double ph = wrap_phi(p0 + 0.5 * t.dph * (1 + x[std::size_t(kp)]));
          const double dw = 0.25 * (tb - ta) * t.dph * w[std::size_t(kt)] * w[std::size_t(kp)] * jac;  // d(omega)
          wc += dw * fc * cf * p.light.radiance(th, ph);
          pdfs(th, ph, at.data());
          for (std::size_t e = 0; e < k; ++e) cm.P[base + e] += dw * at[e];
        }
      }
      cm.W.push_back(wc);
      cm.I += wc;
    }
  }
  return cm;
}

LightTail light_tail(const Problem& p, const std::vector<Estimator>& estimators) {
  LightTail r;
  const std::size_t ne = estimators.size();
  r.relvar.assign(ne, 0.0);
  r.max_weight.assign(ne, 0.0);
  r.missed.assign(ne, 0.0);
  const CellMasses cm = cell_masses(p, ne, [&](double th, double ph, double* out) {
    for (std::size_t e = 0; e < ne; ++e) out[e] = estimator_pdf(p, estimators[e], th, ph);
  });
  const std::vector<double>& W = cm.W;
  const std::vector<double>& P = cm.P;
  const double I = cm.I;
  r.reference = I;
  if (!(I > 0)) return r;
  for (std::size_t c = 0; c < W.size(); ++c) {
    const double wc = W[c] / I;
    if (!(wc > 0)) continue;
    for (std::size_t e = 0; e < ne; ++e) {
      const double pc = P[c * ne + e];
      if (pc > 0) {
        r.relvar[e] += wc * wc / pc;
        r.max_weight[e] = std::max(r.max_weight[e], wc / pc);
      } else {
        r.missed[e] += wc;
      }
    }
  }
  for (auto& v : r.relvar) v -= 1;
  return r;
}

}  // namespace bsdfmix

namespace bsdfmix {

ProductTuning tune_product_fractions(const Problem& p, double max_weight_bound) {
  // Per cell: the integrand's share and each technique's probability.
  const CellMasses cm = cell_masses(p, 3, [&](double th, double ph, double* out) {
    out[0] = estimator_pdf(p, Estimator::Product, th, ph);
    out[1] = estimator_pdf(p, Estimator::Light, th, ph);
    out[2] = estimator_pdf(p, Estimator::UsTab, th, ph);
  });
  struct Cell {
    double W, prod, light, uni;
  };
  std::vector<Cell> cells;
  for (std::size_t c = 0; c < cm.W.size(); ++c) cells.push_back({cm.W[c], cm.P[3 * c], cm.P[3 * c + 1], cm.P[3 * c + 2]});
  const double I = cm.I;
  ProductTuning best;
  best.product_fraction = p.mis.product_fraction;
  best.product_light = p.mis.product_light;
  if (!(I > 0) || !p.has_product) return best;
  // The balance heuristic's density is linear in the fractions: every candidate is
  // scored from the same cell probabilities.
  bool found = false;
  for (const double cp : {0.5, 0.65, 0.8, 0.9, 0.95, 0.98})
    for (const double share : {0.25, 0.5, 0.75}) {
      const double cl = (1 - cp) * share, cu = (1 - cp) * (1 - share);
      double relvar = -1, maxw = 0;
      for (const Cell& c : cells) {
        const double W = c.W / I, P = cp * c.prod + cl * c.light + cu * c.uni;
        if (!(W > 0)) continue;
        if (!(P > 0)) {
          relvar = maxw = std::numeric_limits<double>::infinity();
          break;
        }
        relvar += W * W / P;
        maxw = std::max(maxw, W / P);
      }
      const bool ok = maxw <= max_weight_bound;
      // within the bound, the lowest variance; if no candidate is, the smallest weight
      const bool better = !found || (ok && (!best.bounded || relvar < best.relvar)) ||
                          (!ok && !best.bounded && maxw < best.max_weight);
      if (better) {
        best.product_fraction = cp;
        best.product_light = cl;
        best.relvar = relvar;
        best.max_weight = maxw;
        best.bounded = ok;
        found = true;
      }
    }
  return best;
}

}  // namespace bsdfmix
