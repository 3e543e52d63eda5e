// Woven cloth made of fibers (docs/render.md, "Geometry"): a patch of warp and weft yarns
// in a plain or twill weave, each yarn a twisted bundle of plies of fibers, optionally
// draped over a cylinder or a sphere section. Every fiber is a polyline of control
// points with one radius; the renderer traces them as curves (render/tracer.hpp).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/vec3.hpp"

namespace bsdfmix {
namespace render {

struct ClothParams {
  std::string weave = "plain";  // plain or twill (2/2)
  double size = 1.0;            // the patch is size x size, centred at the origin in the xy plane, normal +z
  double yarn_spacing = 0.05;   // distance between neighbouring yarns (both directions)
  double yarn_radius = 0.02;    // radius of a yarn's cross-section
  int plies = 2;                // plies per yarn, twisted about the yarn's axis
  double ply_twist = 2.0;       // ply turns per unit length along the yarn
  int fibers_per_ply = 12;      // fibers per ply, twisted about the ply's axis
  double fiber_twist = 4.0;     // fiber turns per unit length about the ply axis
  double fiber_radius = 0.002;
  double jitter = 0.15;         // random fiber offsets, as a fraction of the ply radius
  int segments_per_spacing = 6; // polyline segments per yarn spacing along a yarn
  std::uint64_t seed = 1;
  std::string drape = "none";   // none, cylinder (axis y) or sphere
  double drape_radius = 1.0;    // the cylinder's or sphere's radius
};

struct Fiber {
  std::vector<Vec3> points;  // control points (polyline)
  double radius = 0;
};

struct Cloth {
  std::vector<Fiber> fibers;
  Vec3 lo{0, 0, 0}, hi{0, 0, 0};  // bounding box of the control points (radius included)
  std::size_t segments() const;
};

// Throws ConfigError naming `where` for impossible parameters.
Cloth make_cloth(const ClothParams& p, const std::string& where);

}  // namespace render
}  // namespace bsdfmix
