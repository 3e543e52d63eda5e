// The `render` section of a config (docs/render.md, "Config"): image, sampling, lighting,
// camera, cloth and ground, parsed with the config's one-line errors.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "config/config.hpp"
#include "guide/radiance_field.hpp"
#include "render/cloth.hpp"
#include "render/room.hpp"
#include "render/tracer.hpp"
#include "sampling/estimator.hpp"
#include "sampling/lighting.hpp"

namespace bsdfmix {
namespace render {

// How a path's next direction at a fiber or a measured surface is drawn (docs/render.md,
// "Estimators"): the estimators of sampling/estimator.hpp that the renderer offers
// (PathStrategy::renders).
using PathEstimator = Estimator;
inline const char* path_estimator_name(PathEstimator e) { return estimator_name(e); }
inline const PathStrategy& path_strategy(PathEstimator e) { return estimator_info(e).render; }
inline bool uses_light_sampling(PathEstimator e) { return path_strategy(e).light_sampling; }
// guided, guided_product: the estimators that learn the incident radiance (docs/render.md, "Guided paths").
inline bool is_guided(PathEstimator e) { return path_strategy(e).guided; }
// The estimators that need the RGL file the table was imported from (kNeedsRgl).
inline bool uses_rgl(PathEstimator e) { return has_need(e, kNeedsRgl); }

struct Camera {
  Vec3 position{0, -1.3, 1.1}, look_at{0, 0, 0}, up{0, 0, 1};
  double fov_deg = 40;  // vertical
};

struct RenderSettings {
  std::string file;  // the config
  std::string output;
  std::string summary_figure = "figures/summary.png";  // the figure script's summary, relative to output
  int width = 256, height = 256, spp = 64, reference_spp = 1024, stand_in_spp = 256;
  double seconds = 0;
  PathEstimator reference_estimator = PathEstimator::MisLightGmm, stand_in_estimator = PathEstimator::MisLightGmm;
  std::vector<PathEstimator> estimators;
  bool stand_in = true;
  double product_share = 0.5;  // mis_product: the product's share of the light samples, in (0, 1)
  // guided, guided_product (docs/render.md, "Guided paths"): the training iterations, the
  // path vertices guided, the leaves' largest K, and the field's settings (its largest
  // share of guided directions, tree and grid)
  int guide_iterations = 4, guide_depth = 1, guide_k_max = 8;
  guide::FieldSettings guide;
  int max_depth = 24, rr_depth = 3;
  std::uint64_t seed = 1;
  int threads = 0;
  int prepass = 48, prepass_depth = 24;  // the config's 0 is max_depth
  Lighting lighting;  // world space (frame unused)
  Camera camera;
  ClothParams cloth;
  GroundPlane ground;
  double ground_albedo = 0.4;
  // The sphere a hemisphere table (a measured material) is rendered on.
  Vec3 sphere_center{0, 0, 0.29};
  double sphere_radius = 0.35;
  int sphere_rings = 96, sphere_segments = 192;
  // The room around the cloth or the sphere; when enabled its floor replaces the ground.
  RoomParams room;
  // A full-4D fiber table and its stand-in (a mixture file fitted to it): f at fibers from
  // them (docs/render.md, "A full-4D table"); empty: none.
  std::string table_4d, mixture_4d;
};

RenderSettings parse_render(const RenderSection& section);

// The render settings of a config, checked before any work: ConfigError when the config
// has no render or no fit section, or names a bad render setting, or an estimator that
// samples with an RGL file's warps (is_rgl, mis_light_rgl) where the table was not
// imported from one (import.rgl).
RenderSettings render_settings(const Config& config);

}  // namespace render
}  // namespace bsdfmix
