// The renderer's geometry (host/render/cloth.cpp, host/render/tracer.cpp): rays against a
// single straight fiber for every curve type (hit distance, tangent, the fiber's width),
// the self-hit filter of intersect and occluded, the ground plane, make_cloth (fiber count,
// bounding box, determinism per seed, plain and twill crossings, cylinder and sphere drape,
// the ConfigErrors) and a ray hitting a default cloth.
// labels: render
#include <catch2/catch.hpp>

#include <cmath>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "render/cloth.hpp"
#include "render/tracer.hpp"

using namespace bsdfmix;
using namespace bsdfmix::render;

namespace {

const CurveType kTypes[] = {CurveType::FlatLinear, CurveType::RoundLinear, CurveType::FlatBSpline,
                            CurveType::RoundBSpline};
const char* name(CurveType t) {
  switch (t) {
    case CurveType::FlatLinear: return "flat linear";
    case CurveType::RoundLinear: return "round linear";
    case CurveType::FlatBSpline: return "flat B-spline";
    case CurveType::RoundBSpline: return "round B-spline";
  }
  return "?";
}

// A fiber along x from x = -1 to 1 at height z, in the plane y = 0.
Fiber straight_fiber(double z, double r) {
  Fiber f;
  f.points = {{-1, 0, z}, {1, 0, z}};
  f.radius = r;
  return f;
}

Ray down(double x, double y, double z) {
  Ray r;
  r.org = {x, y, z};
  r.dir = {0, 0, -1};
  return r;
}

// The message of the ConfigError make_cloth throws for `p` ("" if none).
std::string cloth_error(const ClothParams& p) {
  try {
    make_cloth(p, "cloth test");
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST_CASE("rays hit a straight fiber within its radius, with the tangent along it", "[render]") {
  const double r = 0.01, d = 5;  // the ray starts d above the fiber's axis
  Cloth cloth;
  cloth.fibers.push_back(straight_fiber(0, r));
  for (CurveType type : kTypes) {
    INFO(name(type));
    const Tracer tracer(cloth, GroundPlane{}, type);
    for (double y : {0.0, 0.3 * r, -0.6 * r, 0.9 * r, -0.95 * r}) {
      INFO("y = " << y / r << " r");
      const Hit h = tracer.intersect(down(0.137, y, d));
      REQUIRE(h.kind == HitKind::Fiber);
      CHECK(h.fiber == 0);
      // Round curves are hit on the tube (d - sqrt(r^2 - y^2)), flat ones on the ribbon
      // through the axis (d): both within r of the axis.
      CHECK(h.t >= d - 1.01 * r);
      CHECK(h.t <= d + 1e-5);
      CHECK(std::abs(h.tangent[0]) == Approx(1).margin(1e-6));
      CHECK(std::abs(h.position[2] - (d - h.t)) < 1e-12);
    }
    for (double y : {1.02 * r, -1.02 * r, 1.5 * r, -3 * r, 0.5}) {
      INFO("y = " << y / r << " r");
      CHECK(tracer.intersect(down(0.137, y, d)).kind == HitKind::None);
      CHECK_FALSE(tracer.occluded(down(0.137, y, d)));
    }
    // Past the fiber's ends.
    CHECK(tracer.intersect(down(1.5, 0, d)).kind == HitKind::None);
  }
}

TEST_CASE("a tilted fiber's tangent follows it for B-splines too", "[render]") {
  Cloth cloth;
  Fiber f;
  // A bent polyline in the xz plane: the tangent at the ray's hit near the middle of the
  // first straight run is (1, 0, 1) / sqrt 2 for linear curves, close to it for B-splines.
  f.points = {{-1, 0, -1}, {-0.5, 0, -0.5}, {0, 0, 0}, {0.5, 0, 0.5}, {1, 0, 0.5}};
  f.radius = 0.01;
  cloth.fibers.push_back(f);
  for (CurveType type : kTypes) {
    INFO(name(type));
    const Tracer tracer(cloth, GroundPlane{}, type);
    const Hit h = tracer.intersect(down(-0.25, 0, 3));
    REQUIRE(h.kind == HitKind::Fiber);
    const double s = std::sqrt(0.5);
    CHECK(std::abs(h.tangent[0] * s + h.tangent[2] * s) == Approx(1).margin(1e-3));
    CHECK(h.position[2] == Approx(-0.25).margin(0.02));
  }
}

TEST_CASE("the self-hit filter skips the fiber a ray leaves, not others", "[render]") {
  const double r = 0.01;
  Cloth cloth;
  cloth.fibers.push_back(straight_fiber(0, r));       // fiber 0
  cloth.fibers.push_back(straight_fiber(-10 * r, r));  // fiber 1, 10 r below
  for (CurveType type : kTypes) {
    INFO(name(type));
    const Tracer tracer(cloth, GroundPlane{}, type);
    // From fiber 0's surface down through it: with the filter, fiber 1 (its top 10 r
    // away, its axis 11 r) is the hit.
    Ray ray = down(0.2, 0, r);
    ray.from_fiber = 0;
    ray.skip = 4 * r;
    Hit h = tracer.intersect(ray);
    REQUIRE(h.kind == HitKind::Fiber);
    CHECK(h.fiber == 1);
    CHECK(h.t >= 10 * r - 0.01 * r);  // Embree's round curves: float accuracy of ~1e-4 r
    CHECK(h.t <= 11 * r + 1e-6);
    CHECK(tracer.occluded(ray));
    // Short of fiber 1 nothing is left once fiber 0 is skipped.
    ray.tfar = 8 * r;
    CHECK(tracer.intersect(ray).kind == HitKind::None);
    CHECK_FALSE(tracer.occluded(ray));

    // From 2.5 r above fiber 0's axis (Embree itself culls flat-curve hits within 2 r of
    // the origin, so the filter is what removes this one): without from_fiber fiber 0 is
    // hit, with it fiber 1, and naming another fiber changes nothing.
    ray = down(0.2, 0, 2.5 * r);
    h = tracer.intersect(ray);
    REQUIRE(h.kind == HitKind::Fiber);
    CHECK(h.fiber == 0);
    CHECK(h.t <= 2.5 * r + 1e-6);
    ray.skip = 4 * r;
    ray.from_fiber = 1;
    CHECK(tracer.intersect(ray).fiber == 0);
    ray.from_fiber = 0;
    CHECK(tracer.intersect(ray).fiber == 1);
    ray.tfar = 8 * r;
    CHECK_FALSE(tracer.occluded(ray));
    ray.from_fiber = 1;
    CHECK(tracer.occluded(ray));
    // A skip short of the hit keeps it (flat: the ribbon at 2.5 r; round: the entry at
    // 1.5 r is skipped, the exit at 3.5 r kept).
    ray.from_fiber = 0;
    ray.skip = 2 * r;
    ray.tfar = 1e30;
    h = tracer.intersect(ray);
    CHECK(h.fiber == 0);
    CHECK(h.t > 2 * r);
  }
}

TEST_CASE("the ground plane is hit at its height, the normal facing the ray", "[render]") {
  GroundPlane ground;
  ground.enabled = true;
  ground.z = -0.5;
  ground.half = 4;
  const Tracer empty(Cloth{}, ground);
  Hit h = empty.intersect(down(0.3, -0.2, 2));
  REQUIRE(h.kind == HitKind::Ground);
  CHECK(h.t == Approx(2.5).margin(1e-6));
  CHECK(h.position[2] == Approx(-0.5).margin(1e-6));
  CHECK(h.normal == Vec3{0, 0, 1});
  CHECK(h.fiber == -1);

  Ray up;
  up.org = {1, 1, -3};
  up.dir = {0, 0, 1};
  h = empty.intersect(up);
  REQUIRE(h.kind == HitKind::Ground);
  CHECK(h.t == Approx(2.5).margin(1e-6));
  CHECK(h.normal == Vec3{0, 0, -1});
  CHECK(empty.occluded(up));
  up.tfar = 2;
  CHECK_FALSE(empty.occluded(up));

  CHECK(empty.intersect(down(5, 0, 2)).kind == HitKind::None);  // past the square
  CHECK(Tracer(Cloth{}, GroundPlane{}).intersect(down(0, 0, 2)).kind == HitKind::None);

  // With a fiber above it, the fiber comes first; beside it, the ground.
  Cloth cloth;
  cloth.fibers.push_back(straight_fiber(0, 0.01));
  const Tracer both(cloth, ground);
  CHECK(both.intersect(down(0, 0, 2)).kind == HitKind::Fiber);
  CHECK(both.intersect(down(0, 0.5, 2)).kind == HitKind::Ground);
}

TEST_CASE("make_cloth lays out yarns, plies and fibers", "[render]") {
  ClothParams p;  // 1 x 1, spacing 0.05: 20 yarns each way
  const Cloth cloth = make_cloth(p, "cloth test");
  const int yarns = 20, steps = 20 * p.segments_per_spacing;
  REQUIRE(cloth.fibers.size() == std::size_t(2 * yarns * p.plies * p.fibers_per_ply));
  CHECK(cloth.segments() == cloth.fibers.size() * steps);
  for (const Fiber& f : cloth.fibers) {
    REQUIRE(f.points.size() == std::size_t(steps + 1));
    CHECK(f.radius == p.fiber_radius);
    for (const Vec3& q : f.points)
      for (int d = 0; d < 3; ++d) {
        CHECK(q[d] - f.radius >= cloth.lo[d]);
        CHECK(q[d] + f.radius <= cloth.hi[d]);
      }
  }
  // The box: the patch in x and y, and the yarns' height (undulation a plus the yarn's
  // radius) in z.
  CHECK(cloth.lo[0] == Approx(-0.5).margin(0.03));
  CHECK(cloth.hi[1] == Approx(0.5).margin(0.03));
  CHECK(cloth.hi[2] <= 2 * p.yarn_radius + p.fiber_radius + 1e-12);
  CHECK(cloth.lo[2] >= -2 * p.yarn_radius - p.fiber_radius - 1e-12);

  // Deterministic per seed; another seed moves the fibers (jitter).
  const Cloth again = make_cloth(p, "cloth test");
  bool same = true;
  for (std::size_t i = 0; i < cloth.fibers.size(); ++i) same = same && cloth.fibers[i].points == again.fibers[i].points;
  CHECK(same);
  ClothParams other = p;
  other.seed = 2;
  CHECK(make_cloth(other, "cloth test").fibers[0].points != cloth.fibers[0].points);
  ClothParams twill = p;
  twill.weave = "twill";
  const Cloth tw = make_cloth(twill, "cloth test");
  REQUIRE(tw.fibers.size() == cloth.fibers.size());
  CHECK(tw.fibers[0].points != cloth.fibers[0].points);
}

TEST_CASE("make_cloth crosses yarns over and under in the plain and twill patterns", "[render]") {
  // One fiber per yarn at a fixed offset: with no twist and no jitter its height at a
  // crossing (where the centreline is level) is the centreline's +-a plus that offset.
  ClothParams p;
  p.plies = 1;
  p.fibers_per_ply = 1;
  p.ply_twist = p.fiber_twist = p.jitter = 0;
  const double offset = p.yarn_radius / 2 * (1 + std::sqrt(0.5));
  for (const std::string weave : {"plain", "twill"}) {
    INFO(weave);
    p.weave = weave;
    const Cloth cloth = make_cloth(p, "cloth test");
    const int yarns = 20;
    for (int i = 0; i < yarns; ++i)
      for (int j = 0; j < yarns; ++j) {
        const bool warp_over = weave == "plain" ? (i + j) % 2 == 0 : ((i + j) / 2) % 2 == 0;
        const std::size_t s = std::size_t(j * p.segments_per_spacing + p.segments_per_spacing / 2);
        const Vec3& warp = cloth.fibers[i].points[s];         // warp yarn i at weft j
        const Vec3& weft = cloth.fibers[yarns + j].points[std::size_t(i * p.segments_per_spacing + p.segments_per_spacing / 2)];
        CHECK(warp[2] - offset == Approx(warp_over ? p.yarn_radius : -p.yarn_radius).margin(1e-12));
        CHECK(weft[2] - offset == Approx(warp_over ? -p.yarn_radius : p.yarn_radius).margin(1e-12));
        CHECK(warp[1] == Approx(-0.5 + (i + 0.5) * p.yarn_spacing).margin(1e-12));
        CHECK(weft[0] == Approx(-0.5 + (j + 0.5) * p.yarn_spacing).margin(1e-12));
      }
  }
}

TEST_CASE("make_cloth drapes the patch over a cylinder or a sphere", "[render]") {
  ClothParams flat;
  flat.size = 0.5;
  flat.yarn_spacing = 0.1;
  const Cloth base = make_cloth(flat, "cloth test");
  for (const std::string kind : {"cylinder", "sphere"}) {
    INFO(kind);
    ClothParams p = flat;
    p.drape = kind;
    p.drape_radius = 0.8;
    const double R = p.drape_radius;
    const Cloth draped = make_cloth(p, "cloth test");
    REQUIRE(draped.fibers.size() == base.fibers.size());
    double worst = 0;
    for (std::size_t i = 0; i < base.fibers.size(); ++i)
      for (std::size_t k = 0; k < base.fibers[i].points.size(); ++k) {
        const Vec3& q = base.fibers[i].points[k];
        const Vec3& w = draped.fibers[i].points[k];
        // Distance from the cylinder's axis (the sphere's centre) is R + z.
        const double dist = kind == "cylinder" ? std::hypot(w[0], w[2] + R) : std::hypot(w[0], w[1], w[2] + R);
        worst = std::max(worst, std::abs(dist - (R + q[2])));
        if (kind == "cylinder") CHECK(w[1] == q[1]);
      }
    CHECK(worst < 1e-9);
    CHECK(draped.hi[2] < base.hi[2] + 1e-12);  // bent downwards
    CHECK(draped.lo[2] < base.lo[2] - 0.01);
  }
}

TEST_CASE("make_cloth rejects impossible parameters, naming the key", "[render]") {
  struct Bad {
    const char* key;
    void (*set)(ClothParams&);
  };
  const Bad bad[] = {
      {"size", [](ClothParams& p) { p.size = 0; }},
      {"yarn_spacing", [](ClothParams& p) { p.yarn_spacing = 2; }},
      {"yarn_spacing", [](ClothParams& p) { p.yarn_spacing = -0.1; }},
      {"yarn_radius", [](ClothParams& p) { p.yarn_radius = 0.06; }},
      {"plies", [](ClothParams& p) { p.plies = 0; }},
      {"fibers_per_ply", [](ClothParams& p) { p.fibers_per_ply = 0; }},
      {"fiber_radius", [](ClothParams& p) { p.fiber_radius = 0.03; }},
      {"fiber_radius", [](ClothParams& p) { p.fiber_radius = 0; }},
      {"jitter", [](ClothParams& p) { p.jitter = 1.5; }},
      {"segments_per_spacing", [](ClothParams& p) { p.segments_per_spacing = 0; }},
      {"weave", [](ClothParams& p) { p.weave = "satin"; }},
      {"drape", [](ClothParams& p) { p.drape = "cone"; }},
      {"drape_radius", [](ClothParams& p) { p.drape = "sphere", p.drape_radius = 0; }},
      {"drape_radius", [](ClothParams& p) { p.drape = "cylinder", p.drape_radius = 0.1; }},
      {"5 million", [](ClothParams& p) { p.fibers_per_ply = 1000, p.segments_per_spacing = 20; }},
  };
  for (const Bad& b : bad) {
    ClothParams p;
    b.set(p);
    const std::string msg = cloth_error(p);
    INFO("key " << b.key << ": " << msg);
    CHECK(msg.rfind("cloth test: ", 0) == 0);
    CHECK(msg.find(b.key) != std::string::npos);
  }
  // A drape radius is not checked without a drape.
  ClothParams p;
  p.drape_radius = -1;
  CHECK(cloth_error(p).empty());
}

TEST_CASE("rays from above hit a default cloth", "[render]") {
  const Cloth cloth = make_cloth(ClothParams{}, "cloth test");
  for (CurveType type : kTypes) {
    INFO(name(type));
    const Tracer tracer(cloth, GroundPlane{}, type);
    // The crossing next to the centre (the centre itself lies in the open gap between
    // four yarns, as in a real weave).
    const double c = 0.025;
    const Hit h = tracer.intersect(down(c, c, 1));
    REQUIRE(h.kind == HitKind::Fiber);
    CHECK(h.t > 1 - cloth.hi[2] - 1e-6);
    CHECK(h.t < 1 - cloth.lo[2]);
    CHECK(h.fiber >= 0);
    CHECK(h.fiber < std::int64_t(cloth.fibers.size()));
    // Most of the central square is covered.
    int hits = 0, n = 40;
    for (int a = 0; a < n; ++a)
      for (int b = 0; b < n; ++b) hits += tracer.intersect(down(-0.2 + 0.4 * (a + 0.5) / n, -0.2 + 0.4 * (b + 0.5) / n, 1)).kind == HitKind::Fiber;
    INFO("covered " << hits << " of " << n * n);
    CHECK(hits > 0.8 * n * n);
    // A second scene of the same cloth answers every ray the same (deterministic build).
    const Tracer twin(cloth, GroundPlane{}, type);
    bool same = true;
    for (int a = 0; a < n; ++a)
      for (int b = 0; b < n; ++b) {
        const Ray ray = down(-0.2 + 0.4 * (a + 0.5) / n, -0.2 + 0.4 * (b + 0.5) / n, 1);
        const Hit h1 = tracer.intersect(ray), h2 = twin.intersect(ray);
        same = same && h1.fiber == h2.fiber && h1.t == h2.t && h1.tangent == h2.tangent;
      }
    CHECK(same);
  }
}
