// The density of a periodic-phi 2D Gaussian mixture.
#include "fit/gmm.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "core/domain.hpp"
#include "core/vector_math.hpp"

namespace bsdfmix {

namespace {

// A component of positive weight and covariance, as the log densities take it: its log
// normalization (log weight - log 2 pi - log det / 2), its covariance and its mean.
struct LogTerm {
  double lognorm, a, b, c, det, mt, mp;
};

std::vector<LogTerm> log_terms(const Gmm& g) {
  std::vector<LogTerm> out;
  for (int k = 0; k < g.k(); ++k) {
    const double a = g.cov[3 * k], b = g.cov[3 * k + 1], c = g.cov[3 * k + 2];
    const double det = a * c - b * b;
    if (!(det > 0) || !(g.weight[k] > 0)) continue;
    out.push_back({std::log(g.weight[k]) - std::log(2 * kPi) - 0.5 * std::log(det), a, b, c, det, g.mean[2 * k],
                   g.mean[2 * k + 1]});
  }
  return out;
}

// log of weight_k * N(theta, phi + 2 pi m) for each term and image m = -1, 0, 1, into
// `out` (3 values a term).
void term_logs(const std::vector<LogTerm>& terms, double theta, double phi, double* out) {
  std::size_t n = 0;
  for (const LogTerm& q : terms) {
    const double dt = theta - q.mt;
    const double d0 = wrap_phi(phi - q.mp);
    for (int m = -1; m <= 1; ++m) {
      const double dp = d0 + 2 * kPi * m;
      out[n++] = q.lognorm - 0.5 * ((q.c * dt * dt - 2 * q.b * dt * dp + q.a * dp * dp) / q.det);
    }
  }
}

}  // namespace

double gmm_log_density(const Gmm& gmm, double theta, double phi) {
  const std::vector<LogTerm> terms = log_terms(gmm);
  // The logs on the stack for the fits' K (at most kEmMaxK), on the heap past it.
  constexpr std::size_t kStack = 3 * 128;
  double stack[kStack];
  std::vector<double> heap;
  const std::size_t n = 3 * terms.size();
  if (n > kStack) heap.resize(n);
  double* logs = n > kStack ? heap.data() : stack;
  term_logs(terms, theta, phi, logs);
  if (n == 0) return -std::numeric_limits<double>::infinity();
  const double m = *std::max_element(logs, logs + n);
  if (!std::isfinite(m)) return m;
  double s = 0;
  for (std::size_t i = 0; i < n; ++i) s += std::exp(logs[i] - m);
  return m + std::log(s);
}

void gmm_log_densities(const Gmm& gmm, const double* theta, const double* phi, std::size_t n, double* out) {
  const std::vector<LogTerm> comps = log_terms(gmm);
  const std::size_t terms = 3 * comps.size();
  if (terms == 0) {
    std::fill(out, out + n, -std::numeric_limits<double>::infinity());
    return;
  }
  // Blocks of points: their terms (point-major, then component, then image m = -1, 0, 1).
  constexpr std::size_t kBlock = 256;
  std::vector<double> logs(kBlock * terms), top(kBlock);
  for (std::size_t i0 = 0; i0 < n; i0 += kBlock) {
    const std::size_t nb = std::min(kBlock, n - i0);
    for (std::size_t i = 0; i < nb; ++i) {
      double* l = logs.data() + i * terms;
      term_logs(comps, theta[i0 + i], phi[i0 + i], l);
      top[i] = *std::max_element(l, l + terms);
      if (std::isfinite(top[i]))
        for (std::size_t j = 0; j < terms; ++j) l[j] -= top[i];
    }
    exp_in_place(logs.data(), nb * terms);
    for (std::size_t i = 0; i < nb; ++i) {
      if (!std::isfinite(top[i])) {
        out[i0 + i] = top[i];
        continue;
      }
      double s = 0;
      for (std::size_t j = 0; j < terms; ++j) s += logs[i * terms + j];
      out[i0 + i] = top[i] + std::log(s);
    }
  }
}

double gmm_density(const Gmm& gmm, double theta, double phi) {
  return std::exp(gmm_log_density(gmm, theta, phi));
}

bool sub_cell(double s_tt, double s_tp, double s_pp, double dtheta, double dphi) {
  const double wide = 0.5 * std::min(dtheta, dphi);
  const double half_tr = 0.5 * (s_tt + s_pp);
  const double lmin = half_tr - std::sqrt(0.25 * (s_tt - s_pp) * (s_tt - s_pp) + s_tp * s_tp);
  return !(lmin >= wide * wide);
}

}  // namespace bsdfmix
