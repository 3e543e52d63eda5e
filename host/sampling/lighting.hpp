// Incident lighting L_i of a convergence scene, in the table's angular frame: a constant,
// lobes (a sun), a sky gradient and a lat-long environment map. The same function runs
// in kernels/sample.cl (radiance) on the packed floats of pack(); this is its double
// precision reference. Scenes are parsed from YAML in host/scene/scene.cpp.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "core/domain.hpp"
#include "core/vec3.hpp"

namespace bsdfmix {

struct LightLobe {
  Vec3 direction{0, 0, 1};  // unit, world space
  double kappa = 1;         // radiance * exp(kappa (dot(w, direction) - 1))
  double radiance = 0;
};

struct Lighting {
  std::string name = "constant";
  Domain domain = Domain::Fiber;
  // Frame: axis (fiber tangent / surface normal), e1 (phi = 0), e2 = axis x e1. Fiber:
  // w = sin(theta) axis + cos(theta) (cos(phi) e1 + sin(phi) e2); hemisphere:
  // w = cos(theta) axis + sin(theta) (cos(phi) e1 + sin(phi) e2).
  Vec3 axis{1, 0, 0}, e1{0, 0, 1}, e2{0, -1, 0};
  double constant = 1;
  std::vector<LightLobe> lobes;  // at most kMaxLobes
  bool gradient = false;         // ground (dot = -1) .. horizon (0) .. zenith (1), linear in dot(w, up)
  Vec3 up{0, 0, 1};
  double zenith = 0, horizon = 0, ground = 0;
  int env_width = 0, env_height = 0;  // lat-long luminance, row 0 at +z, column 0 at azimuth -pi
  double env_scale = 0;               // 0: no map
  std::vector<float> env;

  static constexpr std::size_t kMaxLobes = 8;
  static constexpr std::size_t kPacked = 64;

  bool is_constant() const { return lobes.empty() && !gradient && env_scale == 0; }
  Vec3 to_world(double theta, double phi) const;
  double radiance_world(const Vec3& w) const;
  double radiance(double theta, double phi) const { return radiance_world(to_world(theta, phi)); }
  // The smallest angular feature (radians): sets the reference's sub-cell quadrature.
  double finest_feature() const;
  std::vector<float> pack() const;  // kernels/sample.cl scene layout
};

// The default frame of a domain: fiber tangent +x with phi = 0 toward +z; hemisphere
// normal +z with phi = 0 toward +x.
Lighting default_lighting(Domain domain, double constant = 1.0);

// Sets the frame from the axis (fiber tangent or surface normal) and the phi = 0
// direction (made orthogonal to the axis); throws ConfigError naming `where`.
void set_frame(Lighting& l, const Vec3& axis, const Vec3& phi0, const std::string& where);

}  // namespace bsdfmix
