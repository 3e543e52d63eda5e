// The scene of a render, built once from its settings: the cloth, the tracer over it and
// the ground or the room, the light sampler, and the view every pass renders
// (render/integrator.hpp).
#pragma once

#include <string>

#include "render/cloth.hpp"
#include "render/integrator.hpp"
#include "render/render_settings.hpp"
#include "render/tracer.hpp"
#include "sampling/light_sampler.hpp"

namespace bsdfmix {
namespace render {

// A fiber table is rendered as woven cloth; a hemisphere table (a measured material) on a
// sphere (the render section's `sphere`), both over the ground, or inside the room (the
// render section's `room`), whose floor replaces the ground.
class RenderScene {
 public:
  // `where` names the render section in errors; `bsdf` must outlive the scene.
  RenderScene(const RenderSettings& s, const TableBsdf& bsdf, const std::string& where);
  RenderScene(const RenderScene&) = delete;
  RenderScene& operator=(const RenderScene&) = delete;

  const Cloth& cloth() const { return cloth_; }
  const SurfaceMesh& surface() const { return surface_; }
  const SurfaceMesh& room() const { return room_; }  // empty without the room
  // "N fibers, M segments" or "a sphere of N triangles", and the room when there is one.
  std::string describe() const;
  // The view at the render's size and depth.
  const SceneView& view() const { return view_; }
  // The view of the pre-pass: prepass x prepass pixels, at most prepass_depth bounces.
  SceneView prepass_view(const RenderSettings& s) const;
  // 1 where the primary ray through the pixel's center meets a fiber or the surface, else 0
  // (material_mask as an image): the material's pixels, by which the figures set their exposure.
  Image cloth_mask() const;

 private:
  Cloth cloth_;
  SurfaceMesh surface_;
  SurfaceMesh room_;
  std::string room_window_;  // the room's window wall (+x, -x, +y, -y, +z)
  Tracer tracer_;
  LightSampler light_;
  SceneView view_;
};

}  // namespace render
}  // namespace bsdfmix
