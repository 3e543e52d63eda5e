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

void compose_map_jacobian(mix::Map m, double theta, double cos_phi, double sin_phi, double j[4]) {
  if (m == mix::Map::ThetaPhi) return;
  double m11, m12, m21, m22;
  if (m == mix::Map::Cylinder) {
    m11 = std::cos(theta);
    m12 = m21 = 0;
    m22 = 1;
  } else {
    const double c = std::cos(0.5 * theta), r = 2 * std::sin(0.5 * theta);
    m11 = c * cos_phi;
    m12 = -r * sin_phi;
    m21 = c * sin_phi;
    m22 = r * cos_phi;
  }
  const double a = j[0], b = j[1], c = j[2], d = j[3];
  j[0] = m11 * a + m12 * c;
  j[1] = m11 * b + m12 * d;
  j[2] = m21 * a + m22 * c;
  j[3] = m21 * b + m22 * d;
}

mix::SliceMixture carry_lighting(const std::vector<mix::Gaussian>& compact, const LocalAxes& f, const LocalAxes& from,
                                 mix::Map to) {
  mix::SliceMixture out;
  out.scale = 1;
  out.map = to;
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
    double j11 = sgn * dot(dwt, f.axis) / rho, j12 = sgn * dot(dwp, f.axis) / rho;
    double j21 = (x * dot(dwt, f.e2) - y * dot(dwt, f.e1)) / rho2;
    double j22 = (x * dot(dwp, f.e2) - y * dot(dwp, f.e1)) / rho2;
    const double s_theta = j11 * j11 * g.s_tt + 2 * j11 * j12 * g.s_tp + j12 * j12 * g.s_pp;
    if (to != mix::Map::ThetaPhi) {  // on into the map's plane, the mean its point there
      double j[4] = {j11, j12, j21, j22};
      compose_map_jacobian(to, r.mu_t, x / rho, y / rho, j);
      j11 = j[0], j12 = j[1], j21 = j[2], j22 = j[3];
      mix::to_map(to, r.mu_t, r.mu_p, r.mu_t, r.mu_p);
    }
    r.s_tt = j11 * j11 * g.s_tt + 2 * j11 * j12 * g.s_tp + j12 * j12 * g.s_pp;
    if (to == mix::Map::Cylinder) r.s_tt += map_curvature_variance(to, std::asin(z), s_theta);
    r.s_tp = j11 * j21 * g.s_tt + (j11 * j22 + j12 * j21) * g.s_tp + j12 * j22 * g.s_pp;
    r.s_pp = j21 * j21 * g.s_tt + 2 * j21 * j22 * g.s_tp + j22 * j22 * g.s_pp;
    // |det J| = cos(theta_w) / rho, times map_jacobian on a map's plane: the component keeps
    // its value per direction (L is a function, not a density)
    r.weight = g.weight * std::abs(j11 * j22 - j12 * j21);
    if (to != mix::Map::Disk && r.s_pp > cap) {  // uniform in phi: keep the correlation coefficient
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
