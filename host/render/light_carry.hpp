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
mix::SliceMixture carry_lighting(const std::vector<mix::Gaussian>& compact, const LocalAxes& f,
                                 const LocalAxes& from = kWorldAxes);

}  // namespace render
}  // namespace bsdfmix
