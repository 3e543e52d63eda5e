// Split-and-merge moves on fitted slice mixtures.
#include "fit/smem.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <thread>
#include <limits>
#include <queue>

#include "core/domain.hpp"
#include "core/vector_math.hpp"
#include "fit/em_internal.hpp"
#include "fit/scheduler.hpp"

namespace bsdfmix {

namespace {

double wrap_diff(double d) { return d - 2 * kPi * std::nearbyint(d / (2 * kPi)); }

// Cells per block of the vectorized exps (exp_in_place: exp(x), 0 below -708, where libm
// takes a slow path for results that underflow).
constexpr std::size_t kBlock = 256;

// Per cell i and component j, log N_j(x_i) (nearest image) at logn[i k + j]; per cell the
// log of the mixture's density, logs[i]; per component its largest log N_j, zmax[j], and
// its log weight, lw[j].
struct LogDensities {
  std::vector<double> logn, logs, zmax, lw;
  LogDensities(const SliceGrid& grid, std::size_t n, const Gmm& gmm) {
    const int k = gmm.k();
    // Per component: inverse covariance, log normalization.
    std::vector<double> ia(k), ib(k), ic(k), lnorm(k);
    lw.resize(k);
    for (int j = 0; j < k; ++j) {
      const double a = gmm.cov[3 * j], b = gmm.cov[3 * j + 1], c = gmm.cov[3 * j + 2];
      const double det = a * c - b * b;
      ia[j] = c / det;
      ib[j] = -b / det;
      ic[j] = a / det;
      lnorm[j] = -std::log(2 * kPi) - 0.5 * std::log(det);
      lw[j] = std::log(std::max(gmm.weight[j], std::numeric_limits<double>::min()));
    }
    const std::size_t K = static_cast<std::size_t>(k);
    logn.resize(n * K);
    logs.resize(n);
    zmax.assign(k, -std::numeric_limits<double>::infinity());
    std::vector<double> e(kBlock * K);
    for (std::size_t i0 = 0; i0 < n; i0 += kBlock) {
      const std::size_t nb = std::min(kBlock, n - i0);
      for (std::size_t i = i0; i < i0 + nb; ++i) {
        double t, ph;
        cell_point(grid, i, t, ph);
        double m = -std::numeric_limits<double>::infinity();
        for (int j = 0; j < k; ++j) {
          const double dt = t - gmm.mean[2 * j], dp = wrap_diff(ph - gmm.mean[2 * j + 1]);
          const double l = lnorm[j] - 0.5 * (ia[j] * dt * dt + 2 * ib[j] * dt * dp + ic[j] * dp * dp);
          logn[i * K + j] = l;
          zmax[j] = std::max(zmax[j], l);
          m = std::max(m, lw[j] + l);
        }
        logs[i] = m;
        for (std::size_t j = 0; j < K; ++j) e[(i - i0) * K + j] = lw[j] + logn[i * K + j] - m;
      }
      exp_in_place(e.data(), nb * K);  // exp_or_zero
      for (std::size_t i = i0; i < i0 + nb; ++i) {
        double s = 0;
        for (std::size_t j = 0; j < K; ++j) s += e[(i - i0) * K + j];
        logs[i] += std::log(s);
      }
    }
  }
};

// Per component j: Z_j = sum_i N_j(x_i) relative to its largest (zsum), the claimed mass
// A_j = sum_i w_i r_ij (mass), and the responsibilities r_ij of the cells of positive
// weight (resp[i K + j], 0 elsewhere), for score_components' second pass.
struct Claims {
  std::vector<double> zsum, mass, resp;
  Claims(const LogDensities& d, const std::vector<double>& w, std::size_t K)
      : zsum(K, 0.0), mass(K, 0.0), resp(w.size() * K, 0.0) {
    const std::size_t n = w.size();
    std::vector<double> z(kBlock * K), r(kBlock * K);
    for (std::size_t i0 = 0; i0 < n; i0 += kBlock) {
      const std::size_t nb = std::min(kBlock, n - i0);
      for (std::size_t i = i0; i < i0 + nb; ++i)
        for (std::size_t j = 0; j < K; ++j) {
          z[(i - i0) * K + j] = d.logn[i * K + j] - d.zmax[j];
          r[(i - i0) * K + j] = d.lw[j] + d.logn[i * K + j] - d.logs[i];
        }
      exp_in_place(z.data(), nb * K);
      exp_in_place(r.data(), nb * K);
      for (std::size_t i = i0; i < i0 + nb; ++i)
        for (std::size_t j = 0; j < K; ++j) {
          zsum[j] += z[(i - i0) * K + j];
          if (w[i] > 0) mass[j] += w[i] * (resp[i * K + j] = r[(i - i0) * K + j]);
        }
    }
  }
};

// The pairs (a, b), a < b, of the largest positive overlap cross_ab / sqrt(self_a self_b),
// at most max_pairs, largest first (ties by index).
std::vector<std::pair<int, int>> merge_pairs(const std::vector<double>& self, const std::vector<double>& cross, int k,
                                             std::size_t max_pairs) {
  std::vector<std::pair<int, int>> out;
  std::vector<std::pair<double, std::pair<int, int>>> pairs;
  for (int a = 0; a < k; ++a)
    for (int b = a + 1; b < k; ++b) {
      const double d = std::sqrt(self[a] * self[b]);
      const double c = d > 0 ? cross[static_cast<std::size_t>(a) * k + b] / d : 0.0;
      if (c > 0) pairs.push_back({c, {a, b}});
    }
  std::sort(pairs.begin(), pairs.end(), [](const auto& x, const auto& y) {
    return x.first != y.first ? x.first > y.first : x.second < y.second;
  });
  for (std::size_t p = 0; p < pairs.size() && p < max_pairs; ++p) out.push_back(pairs[p].second);
  return out;
}

}  // namespace

ComponentScores score_components(const SliceGrid& grid, const std::vector<double>& w, const Gmm& gmm,
                                 std::size_t max_pairs) {
  const int k = gmm.k();
  const std::size_t n = w.size();
  // Pass 1: log N_k(x_i) (nearest image), responsibilities, per-component sums.
  const LogDensities dens(grid, n, gmm);
  const std::vector<double>& logn = dens.logn;
  const std::vector<double>& logs = dens.logs;
  const std::vector<double>& zmax = dens.zmax;
  const std::vector<double>& lw = dens.lw;
  const std::size_t K = static_cast<std::size_t>(k);
  const Claims claimed(dens, w, K);
  const std::vector<double>& mass = claimed.mass;
  const std::vector<double>& zsum = claimed.zsum;
  const std::vector<double>& resp = claimed.resp;
  // The logs the second pass takes per component, once.
  std::vector<double> log_mass(k), log_zsum(k);
  for (int j = 0; j < k; ++j) {
    log_mass[j] = std::log(mass[j]);
    log_zsum[j] = std::log(zsum[j]);
  }
  ComponentScores out;
  out.split.assign(k, 0.0);
  std::vector<double> kl(k, 0.0), self(k, 0.0), cross(static_cast<std::size_t>(k) * k, 0.0);
  // Second and fourth moments of the claimed weights along both covariance axes.
  std::vector<double> ax(2 * k), ay(2 * k), m2(2 * k, 0.0), m4(2 * k, 0.0);
  for (int j = 0; j < k; ++j)
    for (int q = 0; q < 2; ++q) {
      double lambda;
      em_detail::principal_axis(gmm.cov[3 * j], gmm.cov[3 * j + 1], gmm.cov[3 * j + 2], lambda, ax[2 * j + q], ay[2 * j + q], q == 1);
    }
  std::vector<int> active;
  std::vector<double> ract;
  // Per block of cells, log f and f of each (cell, component) that counts (below).
  std::vector<double> logf_of(kBlock * K), f_of(kBlock * K);
  for (std::size_t i0 = 0; i0 < n; i0 += kBlock) {
    const std::size_t nb = std::min(kBlock, n - i0);
    for (std::size_t i = i0; i < i0 + nb; ++i) {
      if (!(w[i] > 0)) continue;
      const double log_w = std::log(w[i]);
      for (std::size_t j = 0; j < K; ++j) {
        const double lr = lw[j] + logn[i * K + j] - logs[i];
        // f log(f / p), f = w r / A, p = N / Z.
        // f log(f / p) in logs (w r can underflow where log f cannot).
        f_of[(i - i0) * K + j] = logf_of[(i - i0) * K + j] = log_w + lr - log_mass[j];
      }
    }
    exp_in_place(f_of.data(), nb * K);
    for (std::size_t i = i0; i < i0 + nb; ++i) {
      if (!(w[i] > 0)) continue;
      active.clear();
      ract.clear();
      double x, y;  // the cell's point, for every component
      cell_point(grid, i, x, y);
      for (int j = 0; j < k; ++j) {
        const double r = resp[i * k + j];
        if (!(r > 0) || !(mass[j] > 0)) continue;
        const double logf = logf_of[(i - i0) * K + std::size_t(j)];
        const double logp = logn[i * k + j] - zmax[j] - log_zsum[j];
        kl[j] += f_of[(i - i0) * K + std::size_t(j)] * (logf - logp);
        self[j] += w[i] * r * r;
        const double dt = x - gmm.mean[2 * j], dp = wrap_diff(y - gmm.mean[2 * j + 1]);
        for (int q = 0; q < 2; ++q) {
          const double u = ax[2 * j + q] * dt + ay[2 * j + q] * dp, u2 = u * u;
          m2[2 * j + q] += w[i] * r * u2;
          m4[2 * j + q] += w[i] * r * u2 * u2;
        }
        if (r > 1e-6) {
          active.push_back(j);
          ract.push_back(r);
        }
      }
      for (std::size_t a = 0; a < active.size(); ++a)
        for (std::size_t b = a + 1; b < active.size(); ++b)
          cross[static_cast<std::size_t>(active[a]) * k + active[b]] += w[i] * ract[a] * ract[b];
    }
  }
  double total = 0;
  for (int j = 0; j < k; ++j) total += mass[j];
  // Split score: the claimed share of the slice times the local divergence.
  for (int j = 0; j < k; ++j) out.split[j] = total > 0 ? mass[j] / total * std::max(kl[j], 0.0) : 0.0;
  out.axis.assign(k, 0);
  for (int j = 0; j < k; ++j) {
    auto kurtosis = [&](int q) { return m2[2 * j + q] > 0 ? m4[2 * j + q] * mass[j] / (m2[2 * j + q] * m2[2 * j + q]) : 3.0; };
    if (mass[j] > 0 && kurtosis(1) < kurtosis(0)) out.axis[j] = 1;
  }
  out.merge = merge_pairs(self, cross, k, max_pairs);
  return out;
}

Gmm split_component(const Gmm& gmm, int j, double floor, int axis) {
  Gmm g = gmm;
  const double a = g.cov[3 * j], b = g.cov[3 * j + 1], c = g.cov[3 * j + 2];
  double lambda, vx, vy;
  em_detail::principal_axis(a, b, c, lambda, vx, vy, axis == 1);
  const double step = 0.5 * std::sqrt(lambda);
  // Each half: covariance minus step^2 v v^T (the pair keeps the parent's moments).
  double na = a - step * step * vx * vx, nb = b - step * step * vx * vy, nc = c - step * step * vy * vy;
  em_detail::floor_covariance(na, nb, nc, floor);
  const double mt = g.mean[2 * j], mp = g.mean[2 * j + 1];
  g.weight[j] *= 0.5;
  g.weight.push_back(g.weight[j]);
  g.mean[2 * j] = mt - step * vx;
  g.mean[2 * j + 1] = wrap_phi(mp - step * vy);
  g.mean.push_back(mt + step * vx);
  g.mean.push_back(wrap_phi(mp + step * vy));
  g.cov[3 * j] = na;
  g.cov[3 * j + 1] = nb;
  g.cov[3 * j + 2] = nc;
  g.cov.insert(g.cov.end(), {na, nb, nc});
  return g;
}

Gmm merge_components(const Gmm& gmm, int i, int j) {
  if (i > j) std::swap(i, j);
  Gmm g = gmm;
  const double wi = g.weight[i], wj = g.weight[j], w = wi + wj;
  const double ti = g.mean[2 * i], pi = g.mean[2 * i + 1];
  const double tj = g.mean[2 * j], pj = pi + wrap_diff(g.mean[2 * j + 1] - pi);
  const double mt = (wi * ti + wj * tj) / w, mp = (wi * pi + wj * pj) / w;
  auto moment = [&](int q, double t, double p) {
    const double dt = t - mt, dp = p - mp;
    return std::array<double, 3>{g.cov[3 * q] + dt * dt, g.cov[3 * q + 1] + dt * dp, g.cov[3 * q + 2] + dp * dp};
  };
  const auto mi = moment(i, ti, pi), mj = moment(j, tj, pj);
  g.weight[i] = w;
  g.mean[2 * i] = mt;
  g.mean[2 * i + 1] = wrap_phi(mp);
  for (int q = 0; q < 3; ++q) g.cov[3 * i + q] = (wi * mi[q] + wj * mj[q]) / w;
  g.weight.erase(g.weight.begin() + j);
  g.mean.erase(g.mean.begin() + 2 * j, g.mean.begin() + 2 * j + 2);
  g.cov.erase(g.cov.begin() + 3 * j, g.cov.begin() + 3 * j + 3);
  return g;
}

Gmm grow_mixture(const Gmm& gmm, const ComponentScores& scores, int k_new, double floor) {
  Gmm g = gmm;
  std::vector<double> score = scores.split;
  std::vector<int> axis = scores.axis;
  score.resize(g.k(), 0.0);
  axis.resize(g.k(), 0);
  while (g.k() < k_new) {
    int worst = 0;
    for (int j = 1; j < g.k(); ++j)
      if (score[j] > score[worst] || (score[j] == score[worst] && g.weight[j] > g.weight[worst])) worst = j;
    g = split_component(g, worst, floor, axis[worst]);
    score[worst] *= 0.5;
    score.push_back(score[worst]);
    axis[worst] = 0;
    axis.push_back(0);
  }
  return g;
}

std::vector<Gmm> smem_candidates(const Gmm& gmm, const ComponentScores& scores, int count, double floor) {
  std::vector<Gmm> out;
  const int k = gmm.k();
  if (k < 3) return out;
  std::vector<int> order(k);
  for (int j = 0; j < k; ++j) order[j] = j;
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return scores.split[a] > scores.split[b]; });
  for (const auto& [i, j] : scores.merge) {
    if (static_cast<int>(out.size()) >= count) break;
    int l = -1;
    for (int c : order)
      if (c != i && c != j) {
        l = c;
        break;
      }
    if (l < 0) continue;
    // Merge first (indices above j shift down by one), then split.
    Gmm g = merge_components(gmm, i, j);
    const int l2 = l > std::max(i, j) ? l - 1 : l;
    out.push_back(split_component(g, l2, floor, scores.axis.empty() ? 0 : scores.axis[l]));
  }
  return out;
}

std::vector<EmResult> split_merge_fit(const EmFitter& fitter, const SliceSet& set, const std::vector<EmTask>& tasks,
                                      const SmemSettings& settings, std::vector<int>* accepted) {
  std::vector<EmResult> best = fitter(set, tasks);
  if (accepted) accepted->assign(tasks.size(), 0);
  const std::size_t threads = std::max(1u, std::thread::hardware_concurrency());
  // A task whose moves all failed tries the next moves of its list in the next round;
  // one that improved starts a fresh list from its new fit.
  std::vector<int> offset(tasks.size(), 0);
  for (int round = 0; round < settings.rounds; ++round) {
    // Moves per task, chosen on the host (in parallel over tasks).
    std::vector<std::vector<Gmm>> moves(tasks.size());
    run_on_workers(tasks.size(), std::min(threads, std::max<std::size_t>(tasks.size(), 1)),
                   [&](std::size_t, std::size_t i) {
                     const EmTask& t = tasks[i];
                     if (!best[i].ok || t.k < 3) return;
                     const double floor = em_detail::cov_floor(set.grid, t.settings);
                     const int want = offset[i] + settings.candidates;
                     const ComponentScores sc = score_components(set.grid, set.weights[t.slice], best[i].gmm,
                                                                 static_cast<std::size_t>(want));
                     moves[i] = smem_candidates(best[i].gmm, sc, want, floor);
                     moves[i].erase(moves[i].begin(),
                                    moves[i].begin() + std::min<std::size_t>(moves[i].size(), offset[i]));
                   });
    std::vector<EmTask> next;
    std::vector<std::size_t> owner;
    for (std::size_t i = 0; i < tasks.size(); ++i)
      for (Gmm& g : moves[i]) {
        EmTask t = tasks[i];
        t.settings.restarts = 1;
        t.init = std::move(g);
        next.push_back(std::move(t));
        owner.push_back(i);
      }
    if (next.empty()) break;
    const std::vector<EmResult> res = fitter(set, next);
    std::vector<EmResult> pick(tasks.size());
    std::vector<bool> improved(tasks.size(), false);
    for (std::size_t m = 0; m < res.size(); ++m) {
      const std::size_t i = owner[m];
      const double bar = improved[i] ? pick[i].loglik : best[i].loglik + 1e-9 * std::max(1.0, std::abs(best[i].loglik));
      if (res[m].ok && res[m].loglik > bar) {
        pick[i] = res[m];
        improved[i] = true;
      }
    }
    for (std::size_t i = 0; i < tasks.size(); ++i)
      if (improved[i]) {
        best[i] = std::move(pick[i]);
        if (accepted) ++(*accepted)[i];
        offset[i] = 0;
      } else {
        offset[i] += settings.candidates;
      }
  }
  return best;
}

Gmm seed_at_residual(const SliceGrid& grid, const std::vector<double>& w, const Gmm& gmm, int k_new, double floor) {
  const std::size_t nt = grid.theta.size(), np = grid.phi.size();
  if (nt < 2 || np < 2 || gmm.k() >= k_new) return gmm;
  const double dt = grid.theta[1] - grid.theta[0], dp = grid.phi[1] - grid.phi[0];
  double total = 0;
  for (double x : w) total += std::max(x, 0.0);
  if (!(total > 0)) return gmm;
  std::vector<double> r(w.size()), px(w.size()), py(w.size());
  for (std::size_t i = 0; i < w.size(); ++i) cell_point(grid, i, px[i], py[i]);
  gmm_log_densities(gmm, px.data(), py.data(), w.size(), r.data());
  exp_in_place(r.data(), r.size());  // gmm_density
  for (std::size_t i = 0; i < w.size(); ++i) r[i] = w[i] - total * r[i] * dt * dp * cell_jacobian(grid, i);
  Gmm out = gmm;
  constexpr int kHalf = 2;  // the 5 x 5 window
  while (out.k() < k_new) {
    const std::size_t at = std::size_t(std::max_element(r.begin(), r.end()) - r.begin());
    if (!(r[at] > 0)) break;
    const long ti = long(at / np), pj = long(at % np);
    double m0 = 0, mt = 0, mp = 0, stt = 0, stp = 0, spp = 0;
    std::vector<std::size_t> window;
    double x0, y0;  // the peak cell in the grid's plane
    cell_point(grid, at, x0, y0);
    for (long a = std::max(0L, ti - kHalf); a <= std::min(long(nt) - 1, ti + kHalf); ++a)
      for (long b = -kHalf; b <= kHalf; ++b) {
        const std::size_t j = std::size_t((pj + b + long(np)) % long(np)), i = std::size_t(a) * np + j;
        window.push_back(i);
        if (!(r[i] > 0)) continue;
        double x, y;
        cell_point(grid, i, x, y);
        x -= x0;
        y = grid.map == Map::Disk ? y - y0 : double(b) * dp;
        m0 += r[i];
        mt += r[i] * x;
        mp += r[i] * y;
        stt += r[i] * x * x;
        stp += r[i] * x * y;
        spp += r[i] * y * y;
      }
    mt /= m0;
    mp /= m0;
    double a = stt / m0 - mt * mt, b = stp / m0 - mt * mp, c = spp / m0 - mp * mp;
    em_detail::floor_covariance(a, b, c, floor);
    const double share = std::min(0.5, m0 / total);
    for (double& x : out.weight) x *= 1 - share;
    out.weight.push_back(share);
    out.mean.push_back(x0 + mt);
    out.mean.push_back(wrap_phi(y0 + mp));
    for (double x : {a, b, c}) out.cov.push_back(x);
    for (std::size_t i : window) r[i] = 0;
  }
  return out;
}

}  // namespace bsdfmix
