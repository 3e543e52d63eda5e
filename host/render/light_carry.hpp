// The scene's distant lighting as a mixture over world directions, carried into the
// local frame of a hit (docs/render.md, "Product sampling"). The world mixture's
// parameterization is latitude-longitude with z up: theta = asin(w_z) in [-pi/2, pi/2],
// phi = atan2(w_y, w_x), Jacobian cos(theta) (the fiber domain's, axis +z, phi = 0 along
// +x); it is fitted to L over (theta, phi), no Jacobian, like the study's lighting
// mixture. At a hit each component is mapped into the frame's (theta, phi): its mean
// through the map of directions, its covariance through the map's Jacobian at the mean,
// its weight times the Jacobian's determinant (so that the component keeps its value as
// a function of direction). Only its compact components are carried (kBroadSigma). The product of the carried lighting with the hit's BSDF
// mixture (the header's product) is what mis_product samples; its pdf is the product's
// own density, so any error of the carried approximation costs variance, never bias.
#pragma once

#include <bsdfmix/mixture.hpp>

#include <cmath>
#include <vector>

#include "render/local_axes.hpp"

namespace bsdfmix {
namespace render {

// Components broader than this (the larger standard deviation, radians) are left out of
// the product: a light much broader than the BSDF's lobes changes little of their shape,
// and light sampling and the BSDF mixture, in the same MIS, cover it.
constexpr double kBroadSigma = 0.5;

// The world mixture's compact components (sigma_max <= kBroadSigma), with their weights
// as in `world` (not renormalized); empty when none is compact.
std::vector<mix::Gaussian> compact_components(const mix::SliceMixture& world);

// The compact components in the frame `f`, linearized at their means: a mixture over the
// frame's (theta, phi), prepared. Near the frame's pole (the fiber axis, the surface
// normal) the map stretches phi without bound; phi standard deviations are capped at
// 2 pi (wider is uniform in phi to 1e-8), the correlation coefficient kept.
// The components are over `from`'s (theta, phi) in the fiber domain's map: the world's
// latitude-longitude (the lighting), or the guide's map (a guide leaf's radiance).
// `to` is the plane of the result: the frame's (theta, phi), or a map's plane (the plane of
// the BSDF mixture the lighting multiplies; mixture.hpp, "Maps").
mix::SliceMixture carry_lighting(const std::vector<mix::Gaussian>& compact, const LocalAxes& f,
                                 const LocalAxes& from = kWorldAxes, mix::Map to = mix::Map::ThetaPhi);

// A carried lobe's Jacobian j = d(theta, phi) / d(source theta, phi) (row-major) taken on
// into map m's plane at the frame's (theta, cos phi, sin phi): j := M j, M = d(x, y) /
// d(theta, phi). ThetaPhi: unchanged. Cylinder: M = [[cos theta, 0], [0, 1]]. Disk, r =
// 2 sin(theta / 2): M = [[cos(theta / 2) cos phi, -r sin phi], [cos(theta / 2) sin phi, r cos phi]].
// |det M| is map_jacobian (cos theta, sin theta).
void compose_map_jacobian(mix::Map m, double theta, double cos_phi, double sin_phi, double j[4]);

// The cylinder's x = sin theta is flat at the fiber's axis, where a linearized lobe would
// have no width in x (and its density no bound): its x variance there gains the delta
// method's second-order term, sin^2 theta s_theta^2 / 2 (s_theta: theta's variance in the
// frame). 0 on the other maps.
inline double map_curvature_variance(mix::Map m, double theta, double s_theta) {
  if (m != mix::Map::Cylinder) return 0;
  const double s = std::sin(theta);
  return 0.5 * s * s * s_theta * s_theta;
}

}  // namespace render
}  // namespace bsdfmix
