// The world lighting mixture of a render: its grid, the frame, the fit and the cache.
#include "render/world_lighting.hpp"

#include <algorithm>
#include <filesystem>

#include "core/format.hpp"
#include "core/progress.hpp"
#include "render/light_carry.hpp"

namespace bsdfmix {
namespace render {

TableMeta world_lighting_grid() { return make_grid(Domain::Fiber, 1, 1, 90, 180, true); }

bool needs_world_lighting(const RenderSettings& s) {
  const auto is = [](PathEstimator e) { return path_strategy(e).product; };
  return std::any_of(s.estimators.begin(), s.estimators.end(), is) || is(s.reference_estimator) ||
         (s.stand_in && is(s.stand_in_estimator));
}

std::vector<mix::Gaussian> world_lighting(const RenderSettings& s, const FitSettings& fit,
                                          const std::string& device_selector, const EngineOptions& engine) {
  Lighting world = s.lighting;
  world.domain = Domain::Fiber;
  set_frame(world, {0, 0, 1}, {1, 0, 0}, s.file + ": render.scene");
  const std::string cache = (std::filesystem::path(s.output) / "light_mixtures").string();
  FitSettings world_fit = fit;
  world_fit.map = "theta_phi";  // carried between frames as (theta, phi) lobes (light_carry)
  const LightMixture m = lighting_mixture(world, world_lighting_grid(), world_fit, cache, device_selector, engine);
  std::vector<mix::Gaussian> compact = compact_components(m.mixture);
  log_line("render: the lighting '" + s.lighting.name + "' over world directions: K " + std::to_string(m.k) + " (" +
           std::to_string(compact.size()) + " compact), L1 " + format_number(100 * m.l1_rel, "%.2f") + "%" +
           (m.cached ? " (cached)" : ""));
  return compact;
}

}  // namespace render
}  // namespace bsdfmix
