// Surfaces of measured materials (docs/render.md, "Measured materials"): a triangle mesh
// with a shading normal per vertex, traced by Embree beside the cloth's curves.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "core/vec3.hpp"

namespace bsdfmix {
namespace render {

struct SurfaceMesh {
  std::vector<Vec3> vertices, normals;          // normals: unit, one per vertex
  std::vector<std::array<unsigned, 3>> triangles;
};

// A UV sphere of `rings` x `segments` quads (two triangles each, one at the poles) with the
// sphere's own normals. ConfigError naming `where` for a non-positive radius or fewer than
// 3 rings or segments.
SurfaceMesh make_sphere(const Vec3& center, double radius, int rings, int segments, const std::string& where);

}  // namespace render
}  // namespace bsdfmix
