// The scene's lighting as a mixture over world directions, for mis_product
// (render/light_carry.hpp): fitted once by the sweep's in-memory entry on a latitude-
// longitude grid, z up, and cached in the render's output directory
// (scene/light_mixture.hpp).
#pragma once

#include <string>
#include <vector>

#include "fit/em.hpp"
#include "render/render_settings.hpp"
#include "scene/light_mixture.hpp"
#include "sweep/fit_settings.hpp"

namespace bsdfmix {
namespace render {

// The grid the world lighting is fitted on: the fiber domain's (theta in [-pi/2, pi/2],
// phi in [-pi, pi)), 90 x 180 cells of 2 degrees.
TableMeta world_lighting_grid();

// True when some estimator of the render (equal-sample, reference or stand-in) is mis_product.
bool needs_world_lighting(const RenderSettings& s);

// The compact components (render/light_carry.hpp) of the lighting of `s` fitted with
// `fit`'s settings on `device_selector` (the engine run as `engine` says), or read from
// its cache under s.output.
std::vector<mix::Gaussian> world_lighting(const RenderSettings& s, const FitSettings& fit,
                                          const std::string& device_selector, const EngineOptions& engine = {});

}  // namespace render
}  // namespace bsdfmix
