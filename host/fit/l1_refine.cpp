// L1 refinement: the objective's reference, its gradient, and the batched L-BFGS walk.
#include "fit/l1_refine.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/domain.hpp"
#include "core/error.hpp"
#include "fit/em_internal.hpp"

namespace bsdfmix {

namespace {

constexpr int kMemory = 6;           // L-BFGS pairs kept
constexpr double kArmijo = 1e-4;     // sufficient decrease
constexpr double kBacktrack = 0.25;  // step factor after a failed trial
constexpr double kConverged = 1e-7;  // relative decrease that ends a walk

double cell_area(const SliceGrid& grid) { return axis_step(grid.theta) * axis_step(grid.phi); }

// The refinement's covariance floor: (half the smaller cell step)^2, a hair above so that
// the float32 file keeps the components "wide" in sweep/fit_error.cpp's sense.
double refine_floor(const SliceGrid& grid) {
  const double h = 0.5 * std::min(axis_step(grid.theta), axis_step(grid.phi));
  return 1.001 * h * h;
}

// Parameters per component: logit of the weight, mean theta, mean phi (unwrapped), and
// L (L11, L21, L22) with covariance floor * I + L L^T.
std::vector<double> to_params(const Gmm& g, double floor) {
  std::vector<double> x(6 * static_cast<std::size_t>(g.k()));
  for (int j = 0; j < g.k(); ++j) {
    double* p = &x[6 * j];
    p[0] = std::log(std::max(g.weight[j], 1e-300));
    p[1] = g.mean[2 * j];
    p[2] = g.mean[2 * j + 1];
    // Covariance minus floor * I, its eigenvalues kept above a small positive value.
    double lambda, vx, vy;
    em_detail::principal_axis(g.cov[3 * j], g.cov[3 * j + 1], g.cov[3 * j + 2], lambda, vx, vy);
    const double minor = std::max(g.cov[3 * j] + g.cov[3 * j + 2] - lambda, 0.0);
    const double l1 = std::max(lambda - floor, 1e-4 * floor), l2 = std::max(minor - floor, 1e-4 * floor);
    const double a = l1 * vx * vx + l2 * vy * vy, b = (l1 - l2) * vx * vy, c = l1 * vy * vy + l2 * vx * vx;
    p[3] = std::sqrt(a);
    p[4] = b / p[3];
    p[5] = std::sqrt(std::max(c - p[4] * p[4], 1e-8 * floor));
  }
  return x;
}

// The mixture of a parameter vector of k components (the channels' amplitudes, if any, after).
Gmm to_gmm(const std::vector<double>& x, double floor, int k) {
  Gmm g;
  g.weight.resize(k);
  g.mean.resize(2 * k);
  g.cov.resize(3 * k);
  double top = -std::numeric_limits<double>::infinity(), sum = 0;
  for (int j = 0; j < k; ++j) top = std::max(top, x[6 * j]);
  for (int j = 0; j < k; ++j) sum += (g.weight[j] = std::exp(x[6 * j] - top));
  for (int j = 0; j < k; ++j) {
    const double* p = &x[6 * j];
    g.weight[j] /= sum;
    g.mean[2 * j] = p[1];
    g.mean[2 * j + 1] = wrap_phi(p[2]);
    g.cov[3 * j] = floor + p[3] * p[3];
    g.cov[3 * j + 1] = p[3] * p[4];
    g.cov[3 * j + 2] = floor + p[4] * p[4] + p[5] * p[5];
  }
  return g;
}

// The gradient in parameter space from the gradient in (weight, mean, covariance).
std::vector<double> param_gradient(const std::vector<double>& x, const Gmm& g, const std::vector<double>& dg) {
  const int k = g.k();
  std::vector<double> out(x.size());
  double mean_dw = 0;
  for (int j = 0; j < k; ++j) mean_dw += g.weight[j] * dg[6 * j];
  for (int j = 0; j < k; ++j) {
    const double* p = &x[6 * j];
    const double* d = &dg[6 * j];
    double* o = &out[6 * j];
    o[0] = g.weight[j] * (d[0] - mean_dw);  // softmax
    o[1] = d[1];
    o[2] = d[2];
    o[3] = 2 * (d[3] * p[3] + d[4] * p[4]);  // d/dL of tr(G (L L^T)) = 2 G L
    o[4] = 2 * (d[4] * p[3] + d[5] * p[4]);
    o[5] = 2 * d[5] * p[5];
  }
  for (std::size_t q = 6 * std::size_t(k); q < x.size(); ++q) out[q] = std::exp(x[q]) * dg[q];  // log b
  return out;
}

double dot(const std::vector<double>& a, const std::vector<double>& b) {
  double s = 0;
  for (std::size_t i = 0; i < a.size(); ++i) s += a[i] * b[i];
  return s;
}

struct Walk {
  std::size_t slice = 0;
  int k = 0;
  std::vector<double> x, g, dir, trial, best;
  double f = std::numeric_limits<double>::infinity(), best_f = std::numeric_limits<double>::infinity();
  double alpha = 1, slope = 0;
  std::vector<std::vector<double>> s, y;  // L-BFGS pairs, oldest first
  int evaluations = 0;
  bool started = false, done = false;

  // The L-BFGS direction (two-loop recursion) and the first trial along it.
  void aim() {
    dir = g;
    const std::size_t m = s.size();
    std::vector<double> a(m);
    for (std::size_t i = m; i-- > 0;) {
      a[i] = dot(s[i], dir) / dot(y[i], s[i]);
      for (std::size_t q = 0; q < dir.size(); ++q) dir[q] -= a[i] * y[i][q];
    }
    double gamma;
    if (m > 0) {
      gamma = dot(s[m - 1], y[m - 1]) / dot(y[m - 1], y[m - 1]);
    } else {  // no curvature yet: a first step moving no parameter by more than 0.01
      double top = 0;
      for (double v : g) top = std::max(top, std::abs(v));
      gamma = top > 0 ? 0.01 / top : 0.0;
    }
    for (double& v : dir) v *= gamma;
    for (std::size_t i = 0; i < m; ++i) {
      const double b = dot(y[i], dir) / dot(y[i], s[i]);
      for (std::size_t q = 0; q < dir.size(); ++q) dir[q] += s[i][q] * (a[i] - b);
    }
    for (double& v : dir) v = -v;
    slope = dot(g, dir);
    if (!(slope < 0)) {  // not a descent direction: forget the curvature, steepest descent
      if (m == 0) {      // a zero (or non-finite) gradient: nothing to walk
        done = true;
        return;
      }
      s.clear();
      y.clear();
      aim();
      return;
    }
    alpha = 1;
    step();
  }
  void step() {
    trial = x;
    for (std::size_t q = 0; q < x.size(); ++q) trial[q] += alpha * dir[q];
  }
  // Takes the evaluation of `trial`.
  void take(double ft, const std::vector<double>& gt, int max_evaluations) {
    ++evaluations;
    if (std::isfinite(ft) && ft < best_f) {
      best_f = ft;
      best = trial;
    }
    if (!started) {
      started = true;
      x = trial;
      f = ft;
      g = gt;
      if (!std::isfinite(f)) done = true;
      else aim();
    } else if (std::isfinite(ft) && ft <= f + kArmijo * alpha * slope) {
      std::vector<double> ds(x.size()), dy(x.size());
      for (std::size_t q = 0; q < x.size(); ++q) {
        ds[q] = trial[q] - x[q];
        dy[q] = gt[q] - g[q];
      }
      if (dot(ds, dy) > 1e-12 * std::sqrt(dot(ds, ds) * dot(dy, dy))) {
        s.push_back(std::move(ds));
        y.push_back(std::move(dy));
        if (s.size() > kMemory) {
          s.erase(s.begin());
          y.erase(y.begin());
        }
      }
      const double decrease = f - ft;
      x = trial;
      f = ft;
      g = gt;
      if (decrease <= kConverged * f) done = true;
      else aim();
    } else {
      alpha *= kBacktrack;
      double top = 0;
      for (double v : dir) top = std::max(top, std::abs(alpha * v));
      if (top < 1e-10) done = true;
      else step();
    }
    if (evaluations >= max_evaluations) done = true;
  }
};

// The channels' amplitudes b_jc of a walk's trial (its entries past 6 K, log b); none for a
// walk without channels.
std::vector<double> amplitudes(const Walk& w) {
  std::vector<double> b(w.trial.begin() + 6 * static_cast<std::ptrdiff_t>(w.k), w.trial.end());
  for (double& v : b) v = std::exp(v);
  return b;
}

}  // namespace

L1Objective l1_objective(const SliceGrid& grid, double kl, double rgb) {
  return {1e-3 / static_cast<double>(std::max<std::size_t>(1, grid.cells())), kl, rgb};
}

L1Weights l1_weights(const L1Objective& objective, bool channels) {
  if (!channels || !(objective.rgb > 0)) return {objective.kl, 0.0};
  const double a = std::min(objective.rgb, 0.99);
  return {objective.kl / (1 - a), a / (1 - a)};
}

std::vector<double> l1_channels(const SliceSet& set, std::size_t s) {
  if (s >= set.rgb.size() || set.rgb[s].empty()) return {};
  const std::size_t n = set.grid.cells();
  const std::vector<double>& v = set.rgb[s];
  if (v.size() != 3 * n)
    throw InputError("slice " + std::to_string(s) + ": " + std::to_string(v.size()) + " channel weights, expected " +
                     std::to_string(3 * n));
  double total = 0;
  for (double x : v) {
    if (!std::isfinite(x)) throw InputError("slice " + std::to_string(s) + ": a channel weight is not finite");
    total += std::abs(x);
  }
  if (!(total > 0)) return {};
  // Channels of the luminance's shape (each within kGreyShare, summed over the three, of
  // its sum's share of the luminance): the luminance's own error draws them.
  if (s < set.weights.size() && set.weights[s].size() == n) {
    const std::vector<double>& y = set.weights[s];
    double y_sum = 0;
    for (double x : y) y_sum += x;
    if (y_sum > 0) {
      double off = 0;
      for (std::size_t c = 0; c < 3; ++c) {
        double c_sum = 0;
        for (std::size_t i = 0; i < n; ++i) c_sum += v[c * n + i];
        const double r = c_sum / y_sum;
        for (std::size_t i = 0; i < n; ++i) off += std::abs(v[c * n + i] - r * y[i]);
      }
      if (off <= kGreyShare * total) return {};
    }
  }
  std::vector<double> out(v.size());
  for (std::size_t i = 0; i < v.size(); ++i) out[i] = v[i] / total;
  return out;
}

int l1_images(double s_pp) {
  const double n = std::floor((6.0 * std::sqrt(std::max(s_pp, 0.0)) + kPi) / (2 * kPi));
  return static_cast<int>(std::min(n, 8.0));
}

std::vector<L1Value> l1_values_reference(const SliceSet& set, const std::vector<L1Query>& queries,
                                         const L1Objective& objective) {
  const double eps = objective.eps;
  const SliceGrid& grid = set.grid;
  const std::size_t n = grid.cells();
  const double area = cell_area(grid);
  std::vector<L1Value> out(queries.size());
  for (std::size_t qi = 0; qi < queries.size(); ++qi) {
    const Gmm& g = queries[qi].gmm;
    const int k = g.k();
    const em_detail::PreparedSlice w = em_detail::prepare_slice(set, queries[qi].slice);
    const bool colour = !queries[qi].rgb_amp.empty();
    const L1Weights weights = l1_weights(objective, colour);
    const double kl = weights.kl, lam = weights.rgb;
    const std::vector<double> ch = colour ? l1_channels(set, queries[qi].slice) : std::vector<double>{};
    if (colour && queries[qi].rgb_amp.size() != 3 * static_cast<std::size_t>(k))
      throw InputError("L1 query: " + std::to_string(queries[qi].rgb_amp.size()) + " channel amplitudes, expected " +
                       std::to_string(3 * k));
    const std::vector<double>& amp = queries[qi].rgb_amp;
    L1Value& v = out[qi];
    v.stats.assign((colour ? 9 : 6) * static_cast<std::size_t>(k), 0.0);
    if (w.w.empty()) continue;
    std::vector<double> norm(k), it(k), ip(k), itp(k);
    std::vector<int> images(k);
    for (int j = 0; j < k; ++j) {
      const double a = g.cov[3 * j], b = g.cov[3 * j + 1], c = g.cov[3 * j + 2], det = a * c - b * b;
      norm[j] = g.weight[j] / (2 * kPi * std::sqrt(det));
      it[j] = c / det;
      itp[j] = -b / det;
      ip[j] = a / det;
      images[j] = l1_images(c);
    }
    auto density = [&](int j, double dt, double dp) {
      return norm[j] * std::exp(-0.5 * (it[j] * dt * dt + 2 * itp[j] * dt * dp + ip[j] * dp * dp));
    };
    std::vector<double> all(k);
    for (std::size_t i = 0; i < n; ++i) {
      double t, p;
      cell_point(grid, i, t, p);
      const double jac = cell_jacobian(grid, i);  // the cell's area over `area`
      double m = 0, mc[3] = {0, 0, 0};
      for (int j = 0; j < k; ++j) {
        const double dt = t - g.mean[2 * j], d0 = wrap_phi(p - g.mean[2 * j + 1]);
        all[j] = 0;
        for (int img = -images[j]; img <= images[j]; ++img) all[j] += density(j, dt, d0 + 2 * kPi * img);
        m += all[j];
        if (colour)
          for (int c = 0; c < 3; ++c) mc[c] += amp[c * k + j] / g.weight[j] * all[j];
      }
      m *= jac;
      for (double& c : mc) c *= jac;
      const double am = std::max(area * m, 1e-30), d = w.w[i] - area * m, rho = std::sqrt(d * d + eps * eps);
      const double s = jac * (d / rho + kl * w.w[i] / am);
      v.objective += rho + (w.w[i] > 0 ? kl * w.w[i] * (std::log(std::max(w.w[i], 1e-30)) - std::log(am)) : 0.0);
      double sc[3] = {0, 0, 0};
      if (colour)
        for (int c = 0; c < 3; ++c) {
          const double e = (ch.empty() ? 0.0 : ch[c * n + i]) - area * mc[c], r = std::sqrt(e * e + eps * eps);
          v.objective += lam * r;
          sc[c] = jac * lam * e / r;
        }
      for (int j = 0; j < k; ++j) {
        const double dt = t - g.mean[2 * j], d0 = wrap_phi(p - g.mean[2 * j + 1]);
        double seff = s;
        if (colour)
          for (int c = 0; c < 3; ++c) seff += amp[c * k + j] / g.weight[j] * sc[c];
        for (int img = -images[j]; img <= images[j]; ++img) {
          const double dp = d0 + 2 * kPi * img, dens = density(j, dt, dp), sn = seff * dens;
          v.stats[0 * k + j] += s * dens;
          v.stats[1 * k + j] += sn * dt;
          v.stats[2 * k + j] += sn * dp;
          v.stats[3 * k + j] += sn * dt * dt;
          v.stats[4 * k + j] += sn * dt * dp;
          v.stats[5 * k + j] += sn * dp * dp;
          if (colour)
            for (int c = 0; c < 3; ++c) v.stats[(6 + c) * k + j] += sc[c] * dens;
        }
      }
    }
  }
  return out;
}

std::vector<double> l1_gradient(const SliceGrid& grid, const Gmm& g, const L1Value& v,
                                const std::vector<double>& rgb_amp) {
  const int k = g.k();
  const double area = cell_area(grid);
  const bool colour = !rgb_amp.empty();
  std::vector<double> out((colour ? 9 : 6) * static_cast<std::size_t>(k));
  for (int j = 0; j < k; ++j) {
    const double a = g.cov[3 * j], b = g.cov[3 * j + 1], c = g.cov[3 * j + 2], det = a * c - b * b;
    const double Ptt = c / det, Ptp = -b / det, Ppp = a / det;  // the inverse covariance
    const double sw = v.stats[0 * k + j], st = v.stats[1 * k + j], sp = v.stats[2 * k + j];
    double s0 = sw;  // the sum the dt .. dp^2 sums go with: the channels' parts added
    if (colour)
      for (int q = 0; q < 3; ++q) {
        const double sc = v.stats[(6 + q) * k + j];
        s0 += rgb_amp[q * k + j] / g.weight[j] * sc;
        out[6 * k + q * k + j] = -area * sc / g.weight[j];
      }
    const double stt = v.stats[3 * k + j], stp = v.stats[4 * k + j], spp = v.stats[5 * k + j];
    double* o = &out[6 * j];
    o[0] = -area * sw / g.weight[j];
    o[1] = -area * (Ptt * st + Ptp * sp);
    o[2] = -area * (Ptp * st + Ppp * sp);
    // -area / 2 (P S2 P - s0 P), S2 = [stt stp; stp spp].
    const double m00 = Ptt * stt + Ptp * stp, m01 = Ptt * stp + Ptp * spp;  // P S2
    const double m10 = Ptp * stt + Ppp * stp, m11 = Ptp * stp + Ppp * spp;
    o[3] = -0.5 * area * (m00 * Ptt + m01 * Ptp - s0 * Ptt);
    o[4] = -0.5 * area * (m00 * Ptp + m01 * Ppp - s0 * Ptp);
    o[5] = -0.5 * area * (m10 * Ptp + m11 * Ppp - s0 * Ppp);
  }
  return out;
}

std::vector<Gmm> refine_l1(const L1Evaluator& evaluate, const SliceSet& set, const std::vector<L1Query>& start,
                           const RefineSettings& settings) {
  const double floor = refine_floor(set.grid);
  const bool colour = settings.rgb > 0 && !set.rgb.empty();
  const L1Objective objective = l1_objective(set.grid, settings.kl, colour ? settings.rgb : 0.0);
  std::vector<Walk> walks(start.size());
  for (std::size_t i = 0; i < start.size(); ++i) {
    walks[i].slice = start[i].slice;
    walks[i].k = start[i].gmm.k();
    walks[i].trial = to_params(start[i].gmm, floor);
    const std::vector<double> ch = colour ? l1_channels(set, start[i].slice) : std::vector<double>{};
    if (!ch.empty()) {  // each channel's amplitudes start as the luminance's weights times its sum
      const int k = start[i].gmm.k();
      const std::size_t n = set.grid.cells();
      for (int c = 0; c < 3; ++c) {
        double sum = 0, abs_sum = 0;
        for (std::size_t q = 0; q < n; ++q) {
          sum += ch[c * n + q];
          abs_sum += std::abs(ch[c * n + q]);
        }
        // A channel of noise around zero starts at a quarter of its absolute sum; an empty
        // one near zero, where the walk can still raise it.
        const double level = std::max({sum, 0.25 * abs_sum, 1e-9});
        for (int j = 0; j < k; ++j) walks[i].trial.push_back(std::log(std::max(start[i].gmm.weight[j], 1e-300) * level));
      }
    }
    walks[i].best = walks[i].trial;
    walks[i].done = settings.evaluations < 1 || start[i].gmm.k() < 1;
  }
  for (;;) {
    std::vector<std::size_t> active;
    std::vector<L1Query> queries;
    for (std::size_t i = 0; i < walks.size(); ++i)
      if (!walks[i].done) {
        active.push_back(i);
        queries.push_back({walks[i].slice, to_gmm(walks[i].trial, floor, walks[i].k),
                           amplitudes(walks[i])});
      }
    if (active.empty()) break;
    const std::vector<L1Value> values = evaluate(set, queries, objective);
    for (std::size_t a = 0; a < active.size(); ++a) {
      Walk& w = walks[active[a]];
      const std::vector<double> dg = l1_gradient(set.grid, queries[a].gmm, values[a], queries[a].rgb_amp);
      std::vector<double> gt = param_gradient(w.trial, queries[a].gmm, dg);
      double ft = values[a].objective;
      for (double v : gt)
        if (!std::isfinite(v)) ft = std::numeric_limits<double>::infinity();
      w.take(ft, gt, settings.evaluations);
    }
  }
  std::vector<Gmm> out;
  out.reserve(walks.size());
  for (const Walk& w : walks) out.push_back(to_gmm(w.best, floor, w.k));
  return out;
}

}  // namespace bsdfmix
