// The scene of a render: cloth, tracer, light sampler and view.
#include "render/render_scene.hpp"

#include <algorithm>

namespace bsdfmix {
namespace render {

namespace {

// The ground plane; off inside the room, whose floor takes its place.
GroundPlane ground_of(const RenderSettings& s) {
  GroundPlane g = s.ground;
  g.half = 4 * std::max(s.cloth.size, 1.0);
  if (s.room.enabled) g.enabled = false;
  return g;
}

Cloth cloth_of(const RenderSettings& s, const TableBsdf& bsdf, const std::string& where) {
  return bsdf.meta().domain == Domain::Fiber ? make_cloth(s.cloth, where + ": render.cloth") : Cloth{};
}

SurfaceMesh surface_of(const RenderSettings& s, const TableBsdf& bsdf, const std::string& where) {
  if (bsdf.meta().domain == Domain::Fiber) return {};
  return make_sphere(s.sphere_center, s.sphere_radius, s.sphere_rings, s.sphere_segments, where + ": render.sphere");
}

}  // namespace

RenderScene::RenderScene(const RenderSettings& s, const TableBsdf& bsdf, const std::string& where)
    : cloth_(cloth_of(s, bsdf, where)),
      surface_(surface_of(s, bsdf, where)),
      room_(make_room(s.room)),
      room_window_(s.room.window),
      tracer_(cloth_, ground_of(s), CurveType::FlatLinear, surface_.triangles.empty() ? nullptr : &surface_,
              room_.triangles.empty() ? nullptr : &room_),
      light_(make_light_sampler(s.lighting)) {
  view_.tracer = &tracer_;
  view_.bsdf = &bsdf;
  view_.lighting = &s.lighting;
  view_.light = &light_;
  view_.camera = s.camera;
  view_.ground_albedo = s.room.enabled ? s.room.albedo : s.ground_albedo;  // one albedo for every ground hit
  view_.fiber_radius = s.cloth.fiber_radius;
  view_.max_depth = s.max_depth;
  view_.rr_depth = s.rr_depth;
  view_.threads = s.threads;
  view_.seed = s.seed;
  view_.product_share = s.product_share;
  view_.width = s.width;
  view_.height = s.height;
}

SceneView RenderScene::prepass_view(const RenderSettings& s) const {
  SceneView pre = view_;
  pre.width = pre.height = s.prepass;
  pre.max_depth = std::min(s.max_depth, s.prepass_depth);
  return pre;
}

std::string RenderScene::describe() const {
  const std::string what =
      !surface_.triangles.empty()
          ? "a sphere of " + std::to_string(surface_.triangles.size()) + " triangles"
          : std::to_string(cloth_.fibers.size()) + " fibers, " + std::to_string(cloth_.segments()) + " segments";
  if (room_.triangles.empty()) return what;
  return what + ", in a room of " + std::to_string(room_.triangles.size()) + " triangles with a window in its " +
         room_window_ + " wall";
}

Image RenderScene::cloth_mask() const {
  const std::vector<std::uint8_t> m = material_mask(view_);
  Image mask(view_.width, view_.height);
  for (int y = 0; y < view_.height; ++y)
    for (int x = 0; x < view_.width; ++x) mask.set_grey(x, y, m[std::size_t(y) * std::size_t(view_.width) + std::size_t(x)]);
  return mask;
}

}  // namespace render
}  // namespace bsdfmix
