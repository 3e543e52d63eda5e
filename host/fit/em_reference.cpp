// The CPU reference of kernels/em.cl: the same weighted EM in double precision.
#include <Eigen/Dense>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "fit/em_internal.hpp"

namespace bsdfmix {
namespace em_detail {

namespace {

constexpr double kTwoPi = 2 * kPi;

double wrap_diff(double d) { return d - kTwoPi * std::nearbyint(d / kTwoPi); }

// E-step constants of one component: mean, inverse covariance, log normalization.
struct Comp {
  double mt, mp;
  Eigen::Matrix2d inv;
  double c0;  // log(weight) - log(2 pi) - 0.5 log det
};

// Splits the heaviest non-empty component to re-seed component j (as em_mstep does).
bool reseed(Gmm& g, std::vector<bool>& empty, int j) {
  const int k = g.k();
  int h = -1;
  for (int i = 0; i < k; ++i)
    if (!empty[i] && (h < 0 || g.weight[i] > g.weight[h])) h = i;
  if (h < 0) return false;
  const double a = g.cov[3 * h], b = g.cov[3 * h + 1], c = g.cov[3 * h + 2];
  double lambda, vx, vy;
  principal_axis(a, b, c, lambda, vx, vy);
  const double step = 0.5 * std::sqrt(lambda);
  const double mt = g.mean[2 * h], mp = g.mean[2 * h + 1];
  g.mean[2 * j] = mt + step * vx;
  g.mean[2 * j + 1] = wrap_phi(mp + step * vy);
  g.mean[2 * h] = mt - step * vx;
  g.mean[2 * h + 1] = wrap_phi(mp - step * vy);
  g.weight[h] *= 0.5;
  g.weight[j] = g.weight[h];
  for (int q = 0; q < 3; ++q) g.cov[3 * j + q] = g.cov[3 * h + q];
  empty[j] = false;
  return true;
}

// The E-step constants of every component of g.
void set_constants(const Gmm& g, std::vector<Comp>& comp) {
  for (int j = 0; j < g.k(); ++j) {
    Eigen::Matrix2d cov;
    cov << g.cov[3 * j], g.cov[3 * j + 1], g.cov[3 * j + 1], g.cov[3 * j + 2];
    comp[j].mt = g.mean[2 * j];
    comp[j].mp = g.mean[2 * j + 1];
    comp[j].inv = cov.inverse();
    comp[j].c0 = std::log(g.weight[j]) - std::log(kTwoPi) - 0.5 * std::log(cov.determinant());
  }
}

// E-step with the statistics centred on the current means: per component j the six sums
// stats[6 j + q] (responsibility times 1, dt, dp, dt^2, dt dp, dp^2); returns the weighted
// log-likelihood. `e`: scratch, one value per component.
double e_step(const SliceGrid& grid, const std::vector<double>& w, const std::vector<Comp>& comp,
              std::vector<double>& e, std::vector<double>& stats) {
  const std::size_t n = w.size();
  const int k = static_cast<int>(comp.size());
  std::fill(stats.begin(), stats.end(), 0.0);
  double L = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (w[i] <= 0) continue;
    double t, ph;
    cell_point(grid, i, t, ph);
    double m = -std::numeric_limits<double>::infinity();
    for (int j = 0; j < k; ++j) {
      const Eigen::Vector2d d(t - comp[j].mt, wrap_diff(ph - comp[j].mp));
      e[j] = comp[j].c0 - 0.5 * d.dot(comp[j].inv * d);
      m = std::max(m, e[j]);
    }
    double s = 0;
    for (int j = 0; j < k; ++j) s += (e[j] = std::exp(e[j] - m));
    L += w[i] * (m + std::log(s));
    const double f = w[i] / s;
    for (int j = 0; j < k; ++j) {
      const double dt = t - comp[j].mt, dp = wrap_diff(ph - comp[j].mp);
      const double rw = f * e[j];
      double* a = &stats[6 * j];
      a[0] += rw;
      a[1] += rw * dt;
      a[2] += rw * dp;
      a[3] += rw * dt * dt;
      a[4] += rw * dt * dp;
      a[5] += rw * dp * dp;
    }
  }
  return L;
}

// M-step from the statistics (as em_mstep): weights, means and floored covariances, empty
// components re-seeded, weights renormalized. False on a numerical failure (no
// responsibility mass, or no component left to split).
bool m_step(Gmm& g, const std::vector<double>& stats, const EmSettings& settings, double floor) {
  const int k = g.k();
  double total = 0;
  for (int j = 0; j < k; ++j) total += stats[6 * j];
  if (!(total > 0) || !std::isfinite(total)) return false;
  std::vector<bool> empty(k);
  for (int j = 0; j < k; ++j) {
    const double* a = &stats[6 * j];
    empty[j] = !(a[0] > settings.min_weight * total);
    if (empty[j]) continue;
    const double dt = a[1] / a[0], dp = a[2] / a[0];
    double ctt = std::max(a[3] / a[0] - dt * dt, 0.0);
    double cpp = std::max(a[5] / a[0] - dp * dp, 0.0);
    const double lim = std::sqrt(ctt * cpp);
    double ctp = std::min(std::max(a[4] / a[0] - dt * dp, -lim), lim);
    floor_covariance(ctt, ctp, cpp, floor);
    g.weight[j] = a[0] / total;
    g.mean[2 * j] += dt;
    g.mean[2 * j + 1] = wrap_phi(g.mean[2 * j + 1] + dp);
    g.cov[3 * j] = ctt;
    g.cov[3 * j + 1] = ctp;
    g.cov[3 * j + 2] = cpp;
  }
  for (int j = 0; j < k; ++j)
    if (empty[j] && !reseed(g, empty, j)) return false;
  double wsum = 0;
  for (int j = 0; j < k; ++j) wsum += g.weight[j];
  for (int j = 0; j < k; ++j) g.weight[j] /= wsum;
  return true;
}

}  // namespace

EmResult run_reference(const SliceGrid& grid, const std::vector<double>& w, const Gmm& init,
                       const EmSettings& settings, double* iterate_seconds) {
  const auto start = std::chrono::steady_clock::now();
  const int k = init.k();
  const double floor = cov_floor(grid, settings);
  EmResult r;
  r.gmm = init;
  Gmm& g = r.gmm;
  std::vector<Comp> comp(k);
  std::vector<double> e(k), stats(6 * static_cast<std::size_t>(k));
  double lprev = 0;
  bool failed = false;
  for (int it = 1; it <= settings.iterations; ++it) {
    set_constants(g, comp);
    const double L = e_step(grid, w, comp, e, stats);
    if (!std::isfinite(L)) {
      failed = true;
      r.iterations = it - 1;
      break;
    }
    if (it >= 2 && settings.tolerance > 0 &&
        std::abs(L - lprev) <= settings.tolerance * std::max(1.0, std::abs(L))) {
      r.iterations = it - 1;
      break;
    }
    lprev = L;
    if (!m_step(g, stats, settings, floor)) {
      failed = true;
      r.iterations = it - 1;
      break;
    }
    r.iterations = it;
  }
  if (iterate_seconds)
    *iterate_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (failed) {
    r.ok = false;
    r.failure = "numerical failure (non-finite log-likelihood or no responsibility mass) after " +
                std::to_string(r.iterations) + " iterations";
    r.loglik = -std::numeric_limits<double>::infinity();
    return r;
  }
  r.loglik = weighted_loglik(grid, w, g);
  r.ok = std::isfinite(r.loglik);
  if (!r.ok) r.failure = "non-finite final log-likelihood";
  return r;
}

}  // namespace em_detail

std::vector<EmResult> em_fit_reference(const SliceSet& set, const std::vector<EmTask>& tasks) {
  using namespace em_detail;
  validate_slices(set);
  validate_tasks(set, tasks);
  std::vector<PreparedSlice> prepared(set.weights.size());
  std::vector<bool> have(set.weights.size(), false);
  std::vector<EmResult> out(tasks.size());
  for (std::size_t ti = 0; ti < tasks.size(); ++ti) {
    const EmTask& t = tasks[ti];
    if (!have[t.slice]) {
      prepared[t.slice] = prepare_slice(set, t.slice);
      have[t.slice] = true;
    }
    const PreparedSlice& ps = prepared[t.slice];
    EmResult& best = out[ti];
    best.ok = false;
    best.loglik = -std::numeric_limits<double>::infinity();
    if (const std::string why = task_failure(ps, t.slice, t.k); !why.empty()) {
      best.failure = why;
      continue;
    }
    std::string first_failure;
    for (int r = 0; r < t.settings.restarts; ++r) {
      EmResult res = run_reference(set.grid, ps.w, task_start(set.grid, ps.w, t, r), t.settings);
      if (!res.ok) {
        if (first_failure.empty()) first_failure = res.failure;
        continue;
      }
      if (!best.ok || res.loglik > best.loglik) best = res;
    }
    if (!best.ok) best.failure = "every restart failed: " + first_failure;
  }
  return out;
}

}  // namespace bsdfmix
