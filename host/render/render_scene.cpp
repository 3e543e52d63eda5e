// The scene of a render: cloth, tracer, light sampler and view.
#include "render/render_scene.hpp"

#include <algorithm>

namespace bsdfmix {
namespace render {

namespace {

GroundPlane ground_of(const RenderSettings& s) {
  GroundPlane g = s.ground;
  g.half = 4 * std::max(s.cloth.size, 1.0);
  return g;
}

}  // namespace

RenderScene::RenderScene(const RenderSettings& s, const FiberBsdf& bsdf, const std::string& where)
    : cloth_(make_cloth(s.cloth, where + ": render.cloth")),
      tracer_(cloth_, ground_of(s)),
      light_(make_light_sampler(s.lighting)) {
  view_.tracer = &tracer_;
  view_.bsdf = &bsdf;
  view_.lighting = &s.lighting;
  view_.light = &light_;
  view_.camera = s.camera;
  view_.ground_albedo = s.ground_albedo;
  view_.fiber_radius = s.cloth.fiber_radius;
  view_.max_depth = s.max_depth;
  view_.rr_depth = s.rr_depth;
  view_.threads = s.threads;
  view_.seed = s.seed;
  view_.width = s.width;
  view_.height = s.height;
}

SceneView RenderScene::prepass_view(const RenderSettings& s) const {
  SceneView pre = view_;
  pre.width = pre.height = s.prepass;
  pre.max_depth = std::min(s.max_depth, s.prepass_depth);
  return pre;
}

Image RenderScene::cloth_mask() const {
  Image mask(view_.width, view_.height);
  for (int y = 0; y < view_.height; ++y)
    for (int x = 0; x < view_.width; ++x) {
      const Hit hit = tracer_.intersect(camera_ray(view_.camera, view_.width, view_.height, x + 0.5, y + 0.5));
      mask.set_grey(x, y, hit.kind == HitKind::Fiber ? 1.f : 0.f);
    }
  return mask;
}

}  // namespace render
}  // namespace bsdfmix
