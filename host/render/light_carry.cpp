// The world lighting mixture carried into a hit's frame: means, covariances, weights.
#include "render/light_carry.hpp"

#include <algorithm>
#include <cmath>

namespace bsdfmix {
namespace render {

std::vector<mix::Gaussian> compact_components(const mix::SliceMixture& world) {
  std::vector<mix::Gaussian> out;
  for (const mix::Gaussian& g : world.components) {
    if (g.sigma_max() <= kBroadSigma) out.push_back(g);
  }
  return out;
}

mix::SliceMixture carry_lighting(const std::vector<mix::Gaussian>& compact, const LocalAxes& f, const LocalAxes& from) {
  mix::SliceMixture out;
  out.scale = 1;
  out.components.reserve(compact.size());
  const bool fiber = f.domain == Domain::Fiber;
  const double sgn = fiber ? 1.0 : -1.0, cap = 4 * kPi * kPi;
  for (const mix::Gaussian& g : compact) {
    const double ct = std::cos(g.mu_t), st = std::sin(g.mu_t), cp = std::cos(g.mu_p), sp = std::sin(g.mu_p);
    // the direction and its derivatives along the source map's theta and phi
    Vec3 w, dwt, dwp;
    for (std::size_t i = 0; i < 3; ++i) {
      w[i] = ct * cp * from.e1[i] + ct * sp * from.e2[i] + st * from.axis[i];
      dwt[i] = -st * cp * from.e1[i] - st * sp * from.e2[i] + ct * from.axis[i];
      dwp[i] = -ct * sp * from.e1[i] + ct * cp * from.e2[i];
    }
    const double z = std::clamp(dot(w, f.axis), -1.0, 1.0), x = dot(w, f.e1), y = dot(w, f.e2);
    const double rho2 = x * x + y * y;
    if (!(rho2 > 1e-12)) continue;  // on the pole itself: left to light sampling
    const double rho = std::sqrt(rho2);
    mix::Gaussian r;
    r.mu_t = fiber ? std::asin(z) : std::acos(z);
    r.mu_p = wrap_phi(std::atan2(y, x));
    // J = d(theta_l, phi_l) / d(theta_w, phi_w); theta_l's Jacobian is rho in both domains
    const double j11 = sgn * dot(dwt, f.axis) / rho, j12 = sgn * dot(dwp, f.axis) / rho;
    const double j21 = (x * dot(dwt, f.e2) - y * dot(dwt, f.e1)) / rho2;
    const double j22 = (x * dot(dwp, f.e2) - y * dot(dwp, f.e1)) / rho2;
    r.s_tt = j11 * j11 * g.s_tt + 2 * j11 * j12 * g.s_tp + j12 * j12 * g.s_pp;
    r.s_tp = j11 * j21 * g.s_tt + (j11 * j22 + j12 * j21) * g.s_tp + j12 * j22 * g.s_pp;
    r.s_pp = j21 * j21 * g.s_tt + 2 * j21 * j22 * g.s_tp + j22 * j22 * g.s_pp;
    // |det J| = cos(theta_w) / rho: the component keeps its value per direction
    r.weight = g.weight * std::abs(j11 * j22 - j12 * j21);
    if (r.s_pp > cap) {  // uniform in phi: keep the correlation coefficient
      r.s_tp *= std::sqrt(cap / r.s_pp);
      r.s_pp = cap;
    }
    const double det = r.s_tt * r.s_pp - r.s_tp * r.s_tp;
    if (!(det > 1e-9 * r.s_tt * r.s_pp)) r.s_tp = std::copysign(std::sqrt((1 - 1e-9) * r.s_tt * r.s_pp), r.s_tp);
    if (r.weight > 0 && std::isfinite(r.weight) && r.s_tt > 0) out.components.push_back(r);
  }
  if (!out.components.empty()) out.prepare();
  return out;
}

}  // namespace render
}  // namespace bsdfmix
