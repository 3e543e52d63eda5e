// Ray tracing of the cloth's fibers (and an optional ground plane) with Embree 3
// (docs/render.md, "Geometry"): fibers as ray-facing flat linear curves (RTC_GEOMETRY_TYPE_
// FLAT_LINEAR_CURVE), the ground as two triangles, the room's walls as triangles reported
// as ground. Thread-safe after construction.
#pragma once

#include <cstdint>
#include <memory>

#include "render/cloth.hpp"
#include "render/surface.hpp"

namespace bsdfmix {
namespace render {

struct Ray {
  Vec3 org{0, 0, 0}, dir{0, 0, 1};  // dir unit
  double tnear = 0, tfar = 1e30;
  // The fiber the ray leaves (-1: none): hits on that fiber closer than `skip` are
  // ignored, so a ray leaving a fiber's ribbon does not hit the same ribbon again.
  std::int64_t from_fiber = -1;
  double skip = 0;
};

enum class HitKind { None, Fiber, Ground, Surface };

struct Hit {
  HitKind kind = HitKind::None;
  double t = 0;
  Vec3 position{0, 0, 0};
  Vec3 tangent{0, 0, 0};  // fibers: unit curve tangent at the hit
  Vec3 normal{0, 0, 0};   // ground and room: unit normal facing the ray's origin; surface: the shading normal
  std::int64_t fiber = -1;
};

enum class CurveType { FlatLinear, RoundLinear, FlatBSpline, RoundBSpline };

struct GroundPlane {
  bool enabled = false;
  double z = 0;        // the plane z = const, normal +z
  double half = 10;    // a square of this half size about the origin
};

class Tracer {
 public:
  // `surface`, when given, is traced too (its triangles, with their shading normals).
  // `room`, when given, too: its triangles are hit as HitKind::Ground, with their geometric
  // normal (its normals are not read) and the hit's position put back onto the triangle's
  // plane, so that a ray leaving a wall starts on it.
  Tracer(const Cloth& cloth, const GroundPlane& ground, CurveType type = CurveType::FlatLinear,
         const SurfaceMesh* surface = nullptr, const SurfaceMesh* room = nullptr);
  ~Tracer();
  Tracer(const Tracer&) = delete;
  Tracer& operator=(const Tracer&) = delete;

  Hit intersect(const Ray& ray) const;
  bool occluded(const Ray& ray) const;  // anything between tnear and tfar

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace render
}  // namespace bsdfmix
