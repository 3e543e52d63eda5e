// What the lighting tests share: random shading frames and the world lighting's value at a
// direction, for checking a mixture carried into a frame (render/light_carry.hpp).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "gaussians.hpp"
#include "render/light_carry.hpp"

namespace bsdfmix::test {

// test::gaussian, prepared.
inline mix::Gaussian prepared_gaussian(double w, double mt, double mp, double st, double sp, double rho) {
  mix::Gaussian g = gaussian(w, mt, mp, st, sp, rho);
  g.prepare();
  return g;
}

// Frame `index` of `seed` (stream 7 of its uniforms): the axis uniform on the sphere, e1
// perpendicular to it.
inline render::LocalAxes random_frame(std::uint64_t seed, std::uint32_t index, Domain d) {
  double u[4];
  mix::uniforms(seed, 7, index, u);
  const double z = 2 * u[0] - 1, a = 2 * kPi * u[1], r = std::sqrt(std::max(0.0, 1 - z * z));
  render::LocalAxes f;
  f.domain = d;
  f.axis = {r * std::cos(a), r * std::sin(a), z};
  const Vec3 any = std::abs(f.axis[2]) < 0.9 ? Vec3{0, 0, 1} : Vec3{1, 0, 0};
  const Vec3 p = normalized(cross(f.axis, any)), q = cross(f.axis, p);
  const double b = 2 * kPi * u[2];
  for (int i = 0; i < 3; ++i) f.e1[i] = std::cos(b) * p[i] + std::sin(b) * q[i];
  f.e2 = cross(f.axis, f.e1);
  return f;
}

// A world mixture's value (sum of weight x density over the world's (theta, phi)) at a direction.
inline double world_value(const std::vector<mix::Gaussian>& comps, const Vec3& w) {
  double th, ph, v = 0;
  render::local_angles(render::kWorldAxes, w, th, ph);
  for (const auto& g : comps) v += g.weight * g.density(th, ph);
  return v;
}

}  // namespace bsdfmix::test
