// Surfaces of measured materials: the sphere mesh.
#include "render/surface.hpp"

#include <cmath>

#include "core/domain.hpp"
#include "core/error.hpp"

namespace bsdfmix {
namespace render {

SurfaceMesh make_sphere(const Vec3& center, double radius, int rings, int segments, const std::string& where) {
  if (!(radius > 0) || !std::isfinite(radius))
    throw ConfigError(where + ": sphere radius " + std::to_string(radius) + " must be positive");
  if (rings < 3 || segments < 3 || rings > 4096 || segments > 4096)
    throw ConfigError(where + ": sphere rings and segments must be in [3, 4096]");
  SurfaceMesh m;
  for (int i = 0; i <= rings; ++i) {
    const double th = kPi * double(i) / double(rings);  // from the top pole (+z)
    for (int j = 0; j <= segments; ++j) {
      const double ph = 2 * kPi * double(j) / double(segments);
      const Vec3 n{std::sin(th) * std::cos(ph), std::sin(th) * std::sin(ph), std::cos(th)};
      m.normals.push_back(n);
      m.vertices.push_back({center[0] + radius * n[0], center[1] + radius * n[1], center[2] + radius * n[2]});
    }
  }
  const unsigned row = unsigned(segments) + 1;
  for (unsigned i = 0; i < unsigned(rings); ++i)
    for (unsigned j = 0; j < unsigned(segments); ++j) {
      const unsigned a = i * row + j, b = a + 1, c = a + row, d = c + 1;
      if (i > 0) m.triangles.push_back({a, c, b});
      if (i + 1 < unsigned(rings)) m.triangles.push_back({b, c, d});
    }
  return m;
}

}  // namespace render
}  // namespace bsdfmix
