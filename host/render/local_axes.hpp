// A hit's local frame and the map between directions and its (theta, phi): the fiber
// frame (sin(theta) = dot(w, axis), axis the tangent), the surface frame (cos(theta) =
// dot(w, axis), axis the normal), and the world's latitude-longitude (the fiber domain's
// map with the axis +z, phi = 0 along +x). phi is measured from e1 toward e2 = axis x e1.
#pragma once

#include "core/domain.hpp"
#include "core/vec3.hpp"

namespace bsdfmix {
namespace render {

struct LocalAxes {
  Vec3 axis, e1, e2;
  Domain domain = Domain::Fiber;
};

// World directions as latitude-longitude with z up: theta = asin(w_z), phi = atan2(w_y, w_x).
inline const LocalAxes kWorldAxes{{0, 0, 1}, {1, 0, 0}, {0, 1, 0}, Domain::Fiber};
// The guide's map (guide/radiance_field.hpp, guide_angles): the axis +x, phi = 0 at the
// zenith +z, phi = pi / 2 toward -y.
inline const LocalAxes kGuideAxes{{1, 0, 0}, {0, 0, 1}, {0, -1, 0}, Domain::Fiber};

// A direction's (theta, phi) in the frame (phi wrapped into [-pi, pi)), and back.
void local_angles(const LocalAxes& f, const Vec3& w, double& theta, double& phi);
Vec3 local_direction(const LocalAxes& f, double theta, double phi);

}  // namespace render
}  // namespace bsdfmix
