// Woven cloth geometry: yarn centrelines undulating over and under each other, plies twisted
// about each centreline, fibers twisted about each ply, then the optional drape.
#include "render/cloth.hpp"

#include <algorithm>
#include <cmath>
#include <random>

#include "core/domain.hpp"
#include "core/error.hpp"

namespace bsdfmix {
namespace render {

namespace {

constexpr double kGoldenAngle = 2.39996322972865332;  // pi (3 - sqrt 5): the sunflower pattern
constexpr double kMaxSegments = 5e6;                 // beyond this the tracer's memory is the limit

// Floor division and non-negative parity, so that crossings left of the first yarn
// (j = -1) continue the pattern.
int floor_div(int a, int b) { return a >= 0 ? a / b : -((-a + b - 1) / b); }
bool even(int a) { return (a % 2 + 2) % 2 == 0; }

// Whether warp yarn i passes over weft yarn j. Plain: over one, under one. Twill 2/2: over
// two, under two, the pattern shifted by one per yarn (the diagonal wale of a twill).
bool warp_over(bool twill, int i, int j) { return twill ? even(floor_div(i + j, 2)) : even(i + j); }

void check(const ClothParams& p, const std::string& where) {
  auto bad = [&](const std::string& what) { throw ConfigError(where + ": " + what); };
  auto num = [](double v) { return std::to_string(v); };
  if (!(p.size > 0) || !std::isfinite(p.size)) bad("size must be > 0 (got " + num(p.size) + ")");
  if (!(p.yarn_spacing > 0) || p.yarn_spacing > p.size)
    bad("yarn_spacing must be in (0, size] (got " + num(p.yarn_spacing) + ")");
  if (!(p.yarn_radius > 0) || p.yarn_radius > p.yarn_spacing)
    bad("yarn_radius must be in (0, yarn_spacing] (got " + num(p.yarn_radius) + ")");
  if (p.plies < 1) bad("plies must be at least 1 (got " + std::to_string(p.plies) + ")");
  if (p.fibers_per_ply < 1) bad("fibers_per_ply must be at least 1 (got " + std::to_string(p.fibers_per_ply) + ")");
  if (!(p.fiber_radius > 0) || p.fiber_radius > p.yarn_radius)
    bad("fiber_radius must be in (0, yarn_radius] (got " + num(p.fiber_radius) + ")");
  if (!(p.jitter >= 0 && p.jitter <= 1)) bad("jitter must be in [0, 1] (got " + num(p.jitter) + ")");
  if (p.segments_per_spacing < 1)
    bad("segments_per_spacing must be at least 1 (got " + std::to_string(p.segments_per_spacing) + ")");
  if (!std::isfinite(p.ply_twist) || !std::isfinite(p.fiber_twist)) bad("ply_twist and fiber_twist must be finite");
  if (p.weave != "plain" && p.weave != "twill") bad("unknown weave '" + p.weave + "' (expected plain or twill)");
  if (p.drape != "none" && p.drape != "cylinder" && p.drape != "sphere")
    bad("unknown drape '" + p.drape + "' (expected none, cylinder or sphere)");
  if (p.drape != "none") {
    if (!(p.drape_radius > 0) || !std::isfinite(p.drape_radius))
      bad("drape_radius must be > 0 (got " + num(p.drape_radius) + ")");
    // Past these the patch overlaps itself (cylinder) or runs over the pole (sphere).
    const double max_angle = p.drape == "cylinder" ? kPi : kPi / 2;
    if (p.size / 2 / p.drape_radius > max_angle)
      bad("drape_radius " + num(p.drape_radius) + " is too small for size " + num(p.size) + " (the " + p.drape +
          " would wrap the patch past " + (p.drape == "cylinder" ? "itself)" : "the pole)"));
  }
}

// The drape: the flat patch bent onto a cylinder (axis y through (0, 0, -R)) or a sphere
// (centre (0, 0, -R)), z becoming the height above that surface. Lengths along x (and y on
// the sphere) are kept on the surface z = 0.
Vec3 drape(const std::string& kind, double R, const Vec3& p) {
  if (kind == "cylinder") {
    const double a = p[0] / R;
    return {(R + p[2]) * std::sin(a), p[1], (R + p[2]) * std::cos(a) - R};
  }
  if (kind == "sphere") {
    const double a = p[0] / R, b = p[1] / R;
    return {(R + p[2]) * std::sin(a) * std::cos(b), (R + p[2]) * std::sin(b), (R + p[2]) * std::cos(a) * std::cos(b) - R};
  }
  return p;
}

}  // namespace

std::size_t Cloth::segments() const {
  std::size_t n = 0;
  for (const Fiber& f : fibers) n += f.points.empty() ? 0 : f.points.size() - 1;
  return n;
}

Cloth make_cloth(const ClothParams& p, const std::string& where) {
  check(p, where);
  const bool twill = p.weave == "twill";
  // Yarns per direction: as many as fit at the spacing (the tolerance absorbs size / spacing
  // landing just under an integer in floating point).
  const int yarns = std::max(1, static_cast<int>(std::floor(p.size / p.yarn_spacing + 1e-9)));
  const int steps = std::max(1, static_cast<int>(std::lround(p.size / p.yarn_spacing * p.segments_per_spacing)));
  const double fibers = 2.0 * yarns * p.plies * p.fibers_per_ply;
  if (fibers * steps > kMaxSegments)
    throw ConfigError(where + ": " + std::to_string(static_cast<long long>(fibers * steps)) +
                      " fiber segments, more than the limit of 5 million (raise yarn_spacing or lower plies, "
                      "fibers_per_ply or segments_per_spacing)");

  const double half = p.size / 2, a = p.yarn_radius, rp = p.yarn_radius / 2;
  auto yarn_pos = [&](int i) { return -half + (i + 0.5) * p.yarn_spacing; };

  // Per-fiber offsets in the ply's cross-section: sunflower radius and angle plus jitter,
  // drawn in a fixed order (yarn, ply, fiber) so a seed always gives the same cloth.
  std::mt19937_64 rng(p.seed);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);

  Cloth cloth;
  cloth.fibers.reserve(static_cast<std::size_t>(fibers));
  for (int dir = 0; dir < 2; ++dir) {      // 0: warp along x, 1: weft along y
    for (int i = 0; i < yarns; ++i) {
      const double across = yarn_pos(i);
      // Centreline height at crossing j (the yarn of the other direction at yarn_pos(j)).
      auto crossing_z = [&](int j) {
        const bool over = dir == 0 ? warp_over(twill, i, j) : !warp_over(twill, j, i);
        return over ? a : -a;
      };
      // Centreline at the along-yarn coordinate u, and its derivative dz/du: a cosine
      // blend between the heights of the two crossings around u.
      auto centre = [&](double u, double& dz) {
        const double c = (u - yarn_pos(0)) / p.yarn_spacing;
        const int j = static_cast<int>(std::floor(c));
        const double t = c - j, z0 = crossing_z(j), z1 = crossing_z(j + 1);
        dz = (z1 - z0) * kPi / 2 * std::sin(kPi * t) / p.yarn_spacing;
        const double z = z0 + (z1 - z0) * (1 - std::cos(kPi * t)) / 2;
        return dir == 0 ? Vec3{u, across, z} : Vec3{across, u, z};
      };

      for (int k = 0; k < p.plies; ++k) {
        for (int f = 0; f < p.fibers_per_ply; ++f) {
          const double rho0 = rp * std::sqrt((f + 0.5) / p.fibers_per_ply);
          // Jitter: radial and tangential displacements of up to jitter * (ply radius).
          const double rho = std::clamp(rho0 + p.jitter * rp * unit(rng), 0.0, rp);
          const double phi = f * kGoldenAngle + p.jitter * rp * unit(rng) / rho0;

          Fiber fiber;
          fiber.radius = p.fiber_radius;
          fiber.points.reserve(steps + 1);
          for (int s = 0; s <= steps; ++s) {
            const double u = -half + p.size * s / steps, arc = u + half;  // arc: distance from the yarn's start
            double dz = 0;
            const Vec3 c = centre(u, dz);
            // Frame: tangent T, normal N in the plane of T and +z, binormal B = T x N.
            const Vec3 T = normalized(dir == 0 ? Vec3{1, 0, dz} : Vec3{0, 1, dz});
            const Vec3 N = normalized({-T[2] * T[0], -T[2] * T[1], 1 - T[2] * T[2]});
            const Vec3 B = {T[1] * N[2] - T[2] * N[1], T[2] * N[0] - T[0] * N[2], T[0] * N[1] - T[1] * N[0]};
            const double theta = 2 * kPi * (static_cast<double>(k) / p.plies + p.ply_twist * arc);
            const double psi = phi + 2 * kPi * p.fiber_twist * arc;
            // Offset: ply centre on a circle of radius rp, fiber about the ply centre.
            const double on = rp * std::cos(theta) + rho * std::cos(psi);
            const double ob = rp * std::sin(theta) + rho * std::sin(psi);
            const Vec3 q{c[0] + on * N[0] + ob * B[0], c[1] + on * N[1] + ob * B[1], c[2] + on * N[2] + ob * B[2]};
            fiber.points.push_back(drape(p.drape, p.drape_radius, q));
          }
          cloth.fibers.push_back(std::move(fiber));
        }
      }
    }
  }

  // Bounding box of the control points, widened by the fiber radius.
  cloth.lo = {HUGE_VAL, HUGE_VAL, HUGE_VAL};
  cloth.hi = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
  for (const Fiber& f : cloth.fibers)
    for (const Vec3& q : f.points)
      for (int d = 0; d < 3; ++d) {
        cloth.lo[d] = std::min(cloth.lo[d], q[d] - f.radius);
        cloth.hi[d] = std::max(cloth.hi[d], q[d] + f.radius);
      }
  return cloth;
}

}  // namespace render
}  // namespace bsdfmix
