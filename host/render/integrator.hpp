// The path tracer (docs/render.md, "Light transport"): unidirectional, bounded depth,
// Russian roulette; at every vertex the hit's Bsdf (render/bsdf.hpp: a fiber's BCSDF, a
// measured surface's BRDF, the ground's Lambertian) drawn as the estimator's strategy has
// it (sampling/estimator.hpp, PathStrategy); the lighting an environment (sun, sky, map).
// Estimators that sample the light add next-event estimation combined with the BSDF sample
// by MIS (power heuristic, beta 2: the two-sample model pbrt uses for direct lighting). Reproducible for a seed: pixel p's
// sample s draws its uniforms from Philox counter {p, s, dimension, 0} under the seed,
// whatever the threads.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>

#include "guide/radiance_field.hpp"
#include "render/light_carry.hpp"
#include "render/table_bsdf.hpp"
#include "render/image_io.hpp"
#include "render/render_settings.hpp"
#include "render/tracer.hpp"
#include "sampling/light_sampler.hpp"

namespace bsdfmix {
namespace render {

struct SceneView {
  const Tracer* tracer = nullptr;
  const TableBsdf* bsdf = nullptr;
  const Lighting* lighting = nullptr;
  const LightSampler* light = nullptr;
  Camera camera;
  double ground_albedo = 0.4;
  double fiber_radius = 0.004;
  int width = 64, height = 64, max_depth = 24, rr_depth = 3;
  int threads = 0;  // 0: every core
  std::uint64_t seed = 1;
  // mis_product: the compact components of the lighting's mixture over world directions
  // (render/light_carry.hpp), the product's share of the light samples, and its pruning
  const std::vector<mix::Gaussian>* world_light = nullptr;
  double product_share = 0.5;
  mix::ProductOptions product{0.99, 32};
  // guided, guided_product (docs/render.md, "Guided paths"): the learned incident radiance
  // (none: the estimators sample as mis_light_gmm; each leaf holds the share of directions
  // drawn from it), the path vertices it guides, and, while it learns, where the training samples go: one vector per image row.
  const guide::RadianceField* guide = nullptr;
  int guide_depth = 1;  // the vertices of a path that are guided, from the camera
  std::vector<std::vector<guide::Sample>>* train = nullptr;
};

struct RenderStats {
  int spp = 0;
  double seconds = 0;
  std::uint64_t rays = 0;
  std::uint64_t vertices = 0;  // path vertices (fiber, surface and ground hits)
  int threads = 1;
  // the cost of a vertex: thread-seconds per vertex, in nanoseconds
  double ns_per_vertex() const { return vertices ? seconds * threads * 1e9 / double(vertices) : 0.0; }
};

// Passes of one sample per pixel, from pass `first` on, accumulated into `sum` (R, G, B
// doubles per pixel, [height][width][3]). `pass_done` is called after every pass with (passes done so far,
// seconds so far) and returns false to stop. Returns the passes done and the rays traced.
RenderStats render_passes(const SceneView& view, PathEstimator estimator, FSource f, int first, int max_passes,
                          std::vector<double>& sum, const std::function<bool(int, double)>& pass_done);

// Theta_o (radians) of every fiber hit of a small render with uniform sampling and the
// table as f: what the scene needs of the table.
std::vector<double> collect_theta_o(const SceneView& view, int spp);

// The primary ray of pixel (x, y) at sub-pixel offset (ux, uy).
Ray camera_ray(const Camera& c, int width, int height, double x, double y);

// The pixels that show the material: 1 where the primary ray through the pixel's centre
// first hits a fiber or the measured surface, 0 where it hits the ground, the room or
// nothing; one byte per pixel, row-major.
std::vector<std::uint8_t> material_mask(const SceneView& view);

}  // namespace render
}  // namespace bsdfmix
