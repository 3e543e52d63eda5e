// Three-vectors of the renderer (double), and the few operations it needs on them.
#pragma once

#include <array>
#include <cmath>

namespace bsdfmix {
namespace render {

using V3 = std::array<double, 3>;

inline double dot(const V3& a, const V3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
inline V3 cross(const V3& a, const V3& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
inline V3 sub(const V3& a, const V3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
inline V3 neg(const V3& v) { return {-v[0], -v[1], -v[2]}; }
// v / |v|; the zero vector stays zero.
inline V3 normalized(const V3& v) {
  const double n = std::sqrt(dot(v, v));
  return n > 0 ? V3{v[0] / n, v[1] / n, v[2] / n} : V3{0, 0, 0};
}

}  // namespace render
}  // namespace bsdfmix
