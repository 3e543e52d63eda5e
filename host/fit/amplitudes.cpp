// Channel amplitudes of fixed Gaussians: the reference sums, the non-negative solves and
// the reweighted walk.
#include "fit/amplitudes.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/error.hpp"
#include "fit/l1_refine.hpp"

namespace bsdfmix {

namespace {

void check_set(const ChannelSet& set) {
  if (set.channels < 1 || set.channels > kMaxChannels)
    throw ConfigError("amplitude fit: " + std::to_string(set.channels) + " channels, expected 1.." +
                      std::to_string(kMaxChannels));
  for (std::size_t s = 0; s < set.values.size(); ++s)
    if (set.values[s].size() != std::size_t(set.channels) * set.grid.cells())
      throw ConfigError("amplitude fit: slice " + std::to_string(s) + " holds " + std::to_string(set.values[s].size()) +
                        " values, expected channels x cells");
}

}  // namespace

bool is_noise(double negative, double abs_sum) { return negative > kNoiseShare * abs_sum; }

double in_domain_mass(Domain d, double mu_t, double s_tt) {
  const double sd = std::sqrt(2.0 * s_tt);
  return 0.5 * (std::erf((theta_hi(d) - mu_t) / sd) - std::erf((theta_lo(d) - mu_t) / sd));
}

double in_domain_mass(const SliceGrid& grid, const Gmm& g, int j) {
  const double mu_t = g.mean[2 * std::size_t(j)], s_tt = g.cov[3 * std::size_t(j)];
  if (grid.map != Map::Disk) {
    const bool cyl = grid.map == Map::Cylinder;
    const double lo = cyl ? -1.0 : theta_lo(grid.domain), hi = cyl ? 1.0 : theta_hi(grid.domain);
    const double sd = std::sqrt(2.0 * s_tt);
    return 0.5 * (std::erf((hi - mu_t) / sd) - std::erf((lo - mu_t) / sd));
  }
  mix::Gaussian c;
  c.weight = 1;
  c.mu_t = mu_t;
  c.mu_p = g.mean[2 * std::size_t(j) + 1];
  c.s_tt = s_tt;
  c.s_tp = g.cov[3 * std::size_t(j) + 1];
  c.s_pp = g.cov[3 * std::size_t(j) + 2];
  c.prepare();
  // Polar quadrature over the disk: 64 rings (midpoints in r) x 256 angles.
  const int nr = 64, na = 256;
  const double rmax = std::sqrt(2.0), dr = rmax / nr, da = 2 * kPi / na;
  double mass = 0;
  for (int a = 0; a < nr; ++a) {
    const double r = (a + 0.5) * dr;
    for (int b = 0; b < na; ++b) mass += c.density(r * std::cos(b * da), r * std::sin(b * da)) * r * dr * da;
  }
  return std::min(mass, 1.0);
}

std::vector<AmplitudeSums> amplitude_sums_reference(const ChannelSet& set, const std::vector<AmplitudeQuery>& queries) {
  check_set(set);
  const SliceGrid& grid = set.grid;
  const std::size_t np = grid.phi.size(), n = grid.cells();
  const int C = set.channels;
  const double dth = axis_step(grid.theta), dph = axis_step(grid.phi), area = dth * dph;
  std::vector<AmplitudeSums> out(queries.size());
  for (std::size_t qi = 0; qi < queries.size(); ++qi) {
    const AmplitudeQuery& q = queries[qi];
    if (q.slice >= set.values.size()) throw ConfigError("amplitude query: slice out of range");
    const Gmm& g = q.gmm;
    const int K = g.k();
    if (q.amp.size() != std::size_t(C * K) || q.delta.size() != std::size_t(C))
      throw ConfigError("amplitude query: amp must hold channels x K values and delta one per channel");
    AmplitudeSums& r = out[qi];
    r.gram.assign(std::size_t(C * K * K), 0.0);
    r.rhs.assign(std::size_t(C * K), 0.0);
    r.l1.assign(std::size_t(C), 0.0);
    std::vector<double> it(K), itp(K), ip(K), norm(K), phi(K);
    std::vector<int> images(K), sub(K);
    for (int j = 0; j < K; ++j) {
      const double a = g.cov[3 * j], b = g.cov[3 * j + 1], c = g.cov[3 * j + 2], det = a * c - b * b;
      it[j] = c / det;
      itp[j] = -b / det;
      ip[j] = a / det;
      norm[j] = area / (2 * kPi * std::sqrt(det));
      images[j] = l1_images(c);
      sub[j] = sub_cell(a, b, c, dth, dph) ? 1 : 0;  // its mean over 3 x 3 points of the cell
    }
    const std::vector<double>& w = set.values[q.slice];
    for (std::size_t i = 0; i < n; ++i) {
      const double t = grid.theta[i / np], p = grid.phi[i % np], jac = cell_jacobian(grid, i);
      for (int j = 0; j < K; ++j) {
        double v = 0;
        for (int sa = -sub[j]; sa <= sub[j]; ++sa)
          for (int sb = -sub[j]; sb <= sub[j]; ++sb) {
            double x = t + sa * dth / 3, y = p + sb * dph / 3;  // the point in the grid's plane
            if (grid.map != Map::ThetaPhi) mix::to_map(grid.map, x, y, x, y);
            const double dt = x - g.mean[2 * j], d0 = wrap_phi(y - g.mean[2 * j + 1]);
            for (int img = -images[j]; img <= images[j]; ++img) {
              const double dp = d0 + 2 * kPi * img;
              v += std::exp(-0.5 * (it[j] * dt * dt + 2 * itp[j] * dt * dp + ip[j] * dp * dp));
            }
          }
        phi[j] = jac * norm[j] * v / (sub[j] ? 9.0 : 1.0);
      }
      for (int c = 0; c < C; ++c) {
        const double wc = w[std::size_t(c) * n + i];
        double res = wc;
        for (int j = 0; j < K; ++j) res -= q.amp[std::size_t(c * K + j)] * phi[j];
        r.l1[c] += std::abs(res);
        const double d = q.delta[c] > 0 ? 1.0 / std::max(std::abs(res), q.delta[c]) : 1.0;
        for (int a = 0; a < K; ++a) {
          const double u = d * phi[a];
          r.rhs[std::size_t(c * K + a)] += u * wc;
          for (int b = 0; b <= a; ++b) r.gram[std::size_t((c * K + a) * K + b)] += u * phi[b];
        }
      }
    }
    for (int c = 0; c < C; ++c)
      for (int a = 0; a < K; ++a)
        for (int b = a + 1; b < K; ++b)
          r.gram[std::size_t((c * K + a) * K + b)] = r.gram[std::size_t((c * K + b) * K + a)];
  }
  return out;
}

std::vector<double> nnls_normal(const std::vector<double>& G, const std::vector<double>& b, int K) {
  using Eigen::MatrixXd;
  using Eigen::VectorXd;
  std::vector<double> a(std::size_t(K), 0.0);
  std::vector<bool> passive(std::size_t(K), false);
  double scale = 0;
  for (int i = 0; i < K; ++i) scale = std::max(scale, std::abs(b[std::size_t(i)]));
  if (!(scale > 0)) return a;
  const double tol = 1e-12 * scale;
  auto gradient = [&](int i) {  // the negative gradient b - G a at i
    double s = b[std::size_t(i)];
    for (int j = 0; j < K; ++j) s -= G[std::size_t(i * K + j)] * a[std::size_t(j)];
    return s;
  };
  // The least-squares solution on the passive set (zero elsewhere).
  auto solve_passive = [&]() {
    std::vector<int> idx;
    for (int i = 0; i < K; ++i)
      if (passive[std::size_t(i)]) idx.push_back(i);
    const int m = static_cast<int>(idx.size());
    MatrixXd Gp(m, m);
    VectorXd bp(m);
    for (int i = 0; i < m; ++i) {
      bp(i) = b[std::size_t(idx[i])];
      for (int j = 0; j < m; ++j) Gp(i, j) = G[std::size_t(idx[i] * K + idx[j])];
    }
    const VectorXd x = Gp.ldlt().solve(bp);
    std::vector<double> s(std::size_t(K), 0.0);
    for (int i = 0; i < m; ++i) s[std::size_t(idx[i])] = x(i);
    return s;
  };
  for (int outer = 0; outer < 3 * K + 10; ++outer) {
    int best = -1;
    double top = tol;
    for (int i = 0; i < K; ++i)
      if (!passive[std::size_t(i)]) {
        const double g = gradient(i);
        if (g > top) top = g, best = i;
      }
    if (best < 0) break;
    passive[std::size_t(best)] = true;
    for (int inner = 0; inner < 3 * K + 10; ++inner) {
      const std::vector<double> s = solve_passive();
      bool feasible = true;
      for (int i = 0; i < K; ++i) feasible = feasible && (!passive[std::size_t(i)] || (s[std::size_t(i)] > 0 && std::isfinite(s[std::size_t(i)])));
      if (feasible) {
        a = s;
        break;
      }
      double alpha = 1;
      for (int i = 0; i < K; ++i)
        if (passive[std::size_t(i)] && !(s[std::size_t(i)] > 0)) {
          const double ai = a[std::size_t(i)], den = ai - s[std::size_t(i)];
          alpha = std::min(alpha, den > 0 && std::isfinite(den) ? ai / den : 0.0);
        }
      for (int i = 0; i < K; ++i) {
        if (!passive[std::size_t(i)]) continue;
        const double si = std::isfinite(s[std::size_t(i)]) ? s[std::size_t(i)] : 0.0;
        a[std::size_t(i)] += alpha * (si - a[std::size_t(i)]);
        if (!(a[std::size_t(i)] > 0)) {
          a[std::size_t(i)] = 0;
          passive[std::size_t(i)] = false;
        }
      }
      if (std::none_of(passive.begin(), passive.end(), [](bool p) { return p; })) break;
    }
  }
  return a;
}

std::vector<double> solve_channel(const std::vector<double>& G, const std::vector<double>& b,
                                  const std::vector<double>& z, double W, int K) {
  std::vector<double> a(std::size_t(K), 0.0);
  const bool keep = !std::isnan(W);
  if (keep && !(W > 0)) return a;
  // The constraint as one heavy row, mu (z . a - W)^2 beside the cells' sum: mu 1e4 times
  // the cells' mean diagonal over z's; a small ridge keeps overlapping components apart.
  double diag = 0, zz = 0;
  for (int i = 0; i < K; ++i) {
    diag += G[std::size_t(i * K + i)];
    zz += z[std::size_t(i)] * z[std::size_t(i)];
  }
  diag /= K;
  if (!(zz > 0)) return a;
  const double mu = keep ? 1e4 * (diag > 0 ? diag : 1.0) * K / zz : 0.0;
  std::vector<double> Gc = G, bc = b;
  for (int i = 0; i < K; ++i) {
    bc[std::size_t(i)] += mu * (keep ? W : 0.0) * z[std::size_t(i)];
    for (int j = 0; j < K; ++j) Gc[std::size_t(i * K + j)] += mu * z[std::size_t(i)] * z[std::size_t(j)];
    Gc[std::size_t(i * K + i)] += 1e-10 * (diag > 0 ? diag : 1.0);
  }
  a = nnls_normal(Gc, bc, K);
  for (double& x : a)
    if (!std::isfinite(x)) x = 0;
  if (!keep) return a;
  double e = 0;
  for (int i = 0; i < K; ++i) e += z[std::size_t(i)] * a[std::size_t(i)];
  if (e > 0 && std::isfinite(e))
    for (double& x : a) x *= W / e;
  else
    std::fill(a.begin(), a.end(), 0.0);
  return a;
}

std::vector<AmplitudeFit> fit_amplitudes(const AmplitudeEvaluator& evaluate, const ChannelSet& set,
                                         const std::vector<AmplitudeProblem>& problems,
                                         const AmplitudeSettings& settings) {
  check_set(set);
  const int C = set.channels;
  const std::size_t n = set.grid.cells();
  struct State {
    int K = 0;
    std::vector<double> z, W, delta, amp, best_amp, best_l1;
    double last = std::numeric_limits<double>::infinity();
    bool done = false;
  };
  std::vector<State> st(problems.size());
  for (std::size_t p = 0; p < problems.size(); ++p) {
    const AmplitudeProblem& pr = problems[p];
    if (pr.slice >= set.values.size()) throw ConfigError("amplitude problem: slice out of range");
    State& s = st[p];
    s.K = pr.gmm.k();
    for (int j = 0; j < s.K; ++j) s.z.push_back(in_domain_mass(set.grid, pr.gmm, j));
    const std::vector<double>& w = set.values[pr.slice];
    for (int c = 0; c < C; ++c) {
      double sum = 0, abs_sum = 0, negative = 0;
      for (std::size_t i = 0; i < n; ++i) {
        const double x = w[std::size_t(c) * n + i];
        sum += x;
        abs_sum += std::abs(x);
        if (x < 0) negative -= x;
      }
      s.W.push_back(is_noise(negative, abs_sum) ? std::numeric_limits<double>::quiet_NaN() : sum);
      s.delta.push_back(settings.delta * abs_sum / double(n));
    }
    s.amp.assign(std::size_t(C * s.K), 0.0);
    s.best_amp = s.amp;
    s.best_l1.assign(std::size_t(C), std::numeric_limits<double>::infinity());
  }
  // Evaluation e: e = 0 unweighted at zero amplitudes; e >= 1 reweighted at the iterate of
  // e - 1, whose L1 error it measures; the last (settings.iterations + 1) only measures.
  for (int e = 0; e <= settings.iterations + 1; ++e) {
    std::vector<AmplitudeQuery> queries;
    std::vector<std::size_t> owner;
    for (std::size_t p = 0; p < problems.size(); ++p) {
      if (st[p].done) continue;
      AmplitudeQuery q;
      q.slice = problems[p].slice;
      q.gmm = problems[p].gmm;
      q.amp = st[p].amp;
      q.delta = e == 0 ? std::vector<double>(std::size_t(C), 0.0) : st[p].delta;
      queries.push_back(std::move(q));
      owner.push_back(p);
    }
    if (queries.empty()) break;
    const std::vector<AmplitudeSums> sums = evaluate(queries);
    for (std::size_t qi = 0; qi < queries.size(); ++qi) {
      State& s = st[owner[qi]];
      const int K = s.K;
      if (e > 0) {  // the iterate's error: each channel keeps its best; stop once the sum no longer falls
        double total = 0;
        for (int c = 0; c < C; ++c) {
          const double l1 = sums[qi].l1[std::size_t(c)];
          total += l1;
          if (l1 < s.best_l1[std::size_t(c)]) {
            s.best_l1[std::size_t(c)] = l1;
            std::copy(s.amp.begin() + long(c) * K, s.amp.begin() + long(c + 1) * K, s.best_amp.begin() + long(c) * K);
          }
        }
        if (!(total < s.last * (1 - 1e-6)) || e == settings.iterations + 1) {
          s.done = true;
          continue;
        }
        s.last = total;
      }
      for (int c = 0; c < C; ++c) {
        const std::vector<double> G(sums[qi].gram.begin() + long(c) * K * K, sums[qi].gram.begin() + long(c + 1) * K * K);
        const std::vector<double> b(sums[qi].rhs.begin() + long(c) * K, sums[qi].rhs.begin() + long(c + 1) * K);
        const std::vector<double> a = solve_channel(G, b, s.z, s.W[std::size_t(c)], K);
        std::copy(a.begin(), a.end(), s.amp.begin() + long(c) * K);
      }
    }
  }
  std::vector<AmplitudeFit> out(problems.size());
  for (std::size_t p = 0; p < problems.size(); ++p) {
    out[p].amp = st[p].best_amp;
    out[p].l1 = st[p].best_l1;
  }
  return out;
}

}  // namespace bsdfmix
