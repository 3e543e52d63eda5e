// The map between directions and a local frame's (theta, phi).
#include "render/local_axes.hpp"

#include <algorithm>
#include <cmath>

namespace bsdfmix {
namespace render {

void local_angles(const LocalAxes& f, const Vec3& w, double& theta, double& phi) {
  const double z = std::clamp(dot(w, f.axis), -1.0, 1.0);
  theta = f.domain == Domain::Fiber ? std::asin(z) : std::acos(z);
  phi = wrap_phi(std::atan2(dot(w, f.e2), dot(w, f.e1)));
}

Vec3 local_direction(const LocalAxes& f, double theta, double phi) {
  const bool fiber = f.domain == Domain::Fiber;
  const double st = std::sin(theta), ct = std::cos(theta), cp = std::cos(phi), sp = std::sin(phi);
  const double a = fiber ? st : ct, r = fiber ? ct : st;
  Vec3 w;
  for (int i = 0; i < 3; ++i) w[i] = a * f.axis[i] + r * (cp * f.e1[i] + sp * f.e2[i]);
  return w;
}

}  // namespace render
}  // namespace bsdfmix
