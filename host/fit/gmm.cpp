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

// log of weight_k * N(theta, phi + 2 pi m) for each component and image, into `out`
// (room for 3 K values); returns how many it wrote.
std::size_t component_logs(const Gmm& g, double theta, double phi, double* out) {
  std::size_t n = 0;
  for (int k = 0; k < g.k(); ++k) {
    const double a = g.cov[3 * k], b = g.cov[3 * k + 1], c = g.cov[3 * k + 2];
    const double det = a * c - b * b;
    if (!(det > 0) || !(g.weight[k] > 0)) continue;
    const double lognorm = std::log(g.weight[k]) - std::log(2 * kPi) - 0.5 * std::log(det);
    const double dt = theta - g.mean[2 * k];
    const double d0 = wrap_phi(phi - g.mean[2 * k + 1]);
    for (int m = -1; m <= 1; ++m) {
      const double dp = d0 + 2 * kPi * m;
      const double q = (c * dt * dt - 2 * b * dt * dp + a * dp * dp) / det;
      out[n++] = lognorm - 0.5 * q;
    }
  }
  return n;
}

}  // namespace

double gmm_log_density(const Gmm& gmm, double theta, double phi) {
  // The logs on the stack for the fits' K (at most kEmMaxK), on the heap past it.
  constexpr std::size_t kStack = 3 * 128;
  double stack[kStack];
  std::vector<double> heap;
  const std::size_t room = 3 * std::size_t(std::max(gmm.k(), 0));
  if (room > kStack) heap.resize(room);
  double* logs = room > kStack ? heap.data() : stack;
  const std::size_t n = component_logs(gmm, theta, phi, logs);
  if (n == 0) return -std::numeric_limits<double>::infinity();
  const double m = *std::max_element(logs, logs + n);
  if (!std::isfinite(m)) return m;
  double s = 0;
  for (std::size_t i = 0; i < n; ++i) s += std::exp(logs[i] - m);
  return m + std::log(s);
}

void gmm_log_densities(const Gmm& gmm, const double* theta, const double* phi, std::size_t n, double* out) {
  // Per component kept (as component_logs): its log normalization and inverse covariance.
  struct Comp {
    double lognorm, a, b, c, det, mt, mp;
  };
  std::vector<Comp> comps;
  for (int k = 0; k < gmm.k(); ++k) {
    const double a = gmm.cov[3 * k], b = gmm.cov[3 * k + 1], c = gmm.cov[3 * k + 2];
    const double det = a * c - b * b;
    if (!(det > 0) || !(gmm.weight[k] > 0)) continue;
    comps.push_back({std::log(gmm.weight[k]) - std::log(2 * kPi) - 0.5 * std::log(det), a, b, c, det, gmm.mean[2 * k],
                     gmm.mean[2 * k + 1]});
  }
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
      for (std::size_t k = 0; k < comps.size(); ++k) {
        const Comp& q = comps[k];
        const double dt = theta[i0 + i] - q.mt;
        const double d0 = wrap_phi(phi[i0 + i] - q.mp);
        for (int m = -1; m <= 1; ++m) {
          const double dp = d0 + 2 * kPi * m;
          l[3 * k + std::size_t(m + 1)] = q.lognorm - 0.5 * ((q.c * dt * dt - 2 * q.b * dt * dp + q.a * dp * dp) / q.det);
        }
      }
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
