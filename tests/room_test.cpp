// The room of `bsdfmix render` (host/render/room.*): its walls traced as ground with the
// normal facing the ray, the window open; the triangles enclose the box but for the window
// (rays from inside escape exactly through it, as often as its solid angle says); the floor
// replaces the ground and the room's albedo the ground's; bad room keys rejected with one
// line naming the key.
// labels: render
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <memory>
#include <random>
#include <string>

#include "config/config.hpp"
#include "core/domain.hpp"
#include "core/error.hpp"
#include "io/table.hpp"
#include "render/render_scene.hpp"
#include "render/room.hpp"
#include "render/tracer.hpp"

using namespace bsdfmix;
using namespace bsdfmix::render;
namespace fs = std::filesystem;

namespace {

// A tiny fiber table, so that configs naming it pass the missing-file check and a scene
// can be built over it.
std::string tiny_table() {
  const fs::path dir = fs::temp_directory_path() / "bsdfmix_room_test";
  fs::create_directories(dir);
  const std::string p = (dir / "t.h5").string();
  if (!fs::exists(p)) {
    const TableMeta m = make_grid(Domain::Fiber, 2, 1, 2, 4, true);
    write_table(p, m, std::vector<float>(16, 1.0f));
  }
  return p;
}

// The cube [-1, 1]^3 with a window of [-0.5, 0.5]^2 in the middle of `wall`.
RoomParams cube(const std::string& wall) {
  RoomParams p;
  p.enabled = true;
  p.min = {-1, -1, -1};
  p.max = {1, 1, 1};
  p.window = wall;
  p.window_min[0] = p.window_min[1] = -0.5;
  p.window_max[0] = p.window_max[1] = 0.5;
  return p;
}

struct RoomTracer {
  Cloth cloth;
  SurfaceMesh mesh;
  std::unique_ptr<Tracer> tracer;
  explicit RoomTracer(const RoomParams& p) : mesh(make_room(p)) {
    tracer = std::make_unique<Tracer>(cloth, GroundPlane{}, CurveType::FlatLinear, nullptr, &mesh);
  }
  Hit shoot(const Vec3& org, const Vec3& dir) const {
    Ray r;
    r.org = org;
    r.dir = normalized(dir);
    return tracer->intersect(r);
  }
};

// The solid angle of the rectangle [u0, u1] x [v0, v1] on a plane at distance d, (u, v)
// measured from the foot of the perpendicular: the signed corner terms
// atan(u v / (d sqrt(u^2 + v^2 + d^2))) summed with alternating signs.
double rect_solid_angle(double u0, double u1, double v0, double v1, double d) {
  auto F = [d](double u, double v) { return std::atan(u * v / (d * std::sqrt(u * u + v * v + d * d))); };
  return F(u1, v1) - F(u0, v1) - F(u1, v0) + F(u0, v0);
}

std::string room_error(const std::string& render_body) {
  try {
    const Config c = parse_config("table: " + tiny_table() + "\nrender:\n" + render_body, "room.yaml");
    parse_render(*c.render);
  } catch (const Error& e) {
    return e.what();
  }
  return "no error";
}

}  // namespace

TEST_CASE("a wall is hit with the normal facing the ray; the window lets the ray out", "[room]") {
  const RoomParams p = cube("+x");
  const RoomTracer rt(p);
  // 2 walls of two triangles each, 3 more, and the window's wall as four rectangles
  CHECK(rt.mesh.triangles.size() == 5 * 2 + 4 * 2);
  CHECK(rt.mesh.normals.size() == rt.mesh.vertices.size());

  // toward the -x wall, the floor and the ceiling: inward normals, the position on the wall
  struct Case { Vec3 dir, normal; int axis; double plane; };
  const Case cases[] = {{{-1, 0.1, 0.2}, {1, 0, 0}, 0, -1.0},
                        {{0.2, 0.3, -1}, {0, 0, 1}, 2, -1.0},
                        {{0.1, -0.3, 1}, {0, 0, -1}, 2, 1.0},
                        {{0.3, 1, 0.1}, {0, -1, 0}, 1, 1.0}};
  for (const Case& c : cases) {
    const Hit h = rt.shoot({0.1, -0.2, 0.3}, c.dir);
    REQUIRE(h.kind == HitKind::Ground);
    for (int i = 0; i < 3; ++i) CHECK(h.normal[i] == c.normal[i]);
    CHECK(h.position[c.axis] == c.plane);  // exactly on the wall's plane
    CHECK(h.t > 0);
  }
  // the +x wall beside the window, from inside: normal -x
  const Hit beside = rt.shoot({0, 0, 0}, {1, 0.8, 0.1});
  REQUIRE(beside.kind == HitKind::Ground);
  CHECK(beside.normal[0] == -1);
  CHECK(beside.position[0] == 1.0);
  // through the window: out
  CHECK(rt.shoot({0, 0, 0}, {1, 0.2, -0.3}).kind == HitKind::None);
  CHECK(rt.shoot({-0.9, 0.1, 0.1}, {1, 0, 0}).kind == HitKind::None);
  // from outside, through the window, a wall is hit from inside: the normal faces the ray
  const Hit in = rt.shoot({2, 0, 0}, {-1, 0.1, 0.05});
  REQUIRE(in.kind == HitKind::Ground);
  CHECK(in.normal[0] == 1);
  CHECK(in.position[0] == -1.0);
  // a ray leaving a wall's hit, inward and grazing, does not hit that wall again
  for (const Case& c : cases) {
    const Hit h = rt.shoot({0.1, -0.2, 0.3}, c.dir);
    Vec3 d{0.5, -0.7, 0.4};
    d = normalized(d);
    for (int i = 0; i < 3; ++i) d[i] -= dot(d, c.normal) * c.normal[i];  // in the wall's plane ...
    for (int i = 0; i < 3; ++i) d[i] += 1e-4 * c.normal[i];               // ... and just off it
    Ray r;
    r.org = h.position;
    r.dir = normalized(d);
    r.tnear = 1e-6;
    const Hit next = rt.tracer->intersect(r);
    if (next.kind == HitKind::Ground) CHECK(next.t > 1e-3);
  }
  // a disabled room has no triangles
  RoomParams off = p;
  off.enabled = false;
  CHECK(make_room(off).triangles.empty());
}

TEST_CASE("the room's triangles enclose the box but for the window", "[room]") {
  // From the cube's centre, every wall's window of [-0.5, 0.5]^2 at distance 1 subtends the
  // same solid angle. Each ray escapes exactly when its line crosses the window (rays
  // within 1e-6 of the window's edge are not judged); the escaping share is the window's
  // solid angle over 4 pi within 3 standard errors of a binomial of that share.
  const double omega = rect_solid_angle(-0.5, 0.5, -0.5, 0.5, 1.0);
  const double share = omega / (4 * kPi);
  const int n = 4000;
  for (const std::string wall : {"+x", "-x", "+y", "-y", "+z"}) {
    INFO("window in the " << wall << " wall");
    const RoomParams p = cube(wall);
    const RoomTracer rt(p);
    const WallAxes a = window_wall(wall);
    std::mt19937_64 rng(7);
    auto uniform = [&rng] { return double(rng() >> 11) * 0x1.0p-53; };
    int escaped = 0, judged = 0, mismatched = 0;
    for (int k = 0; k < n; ++k) {
      const double z = 1 - 2 * uniform(), ph = 2 * kPi * uniform(), s = std::sqrt(std::max(0.0, 1 - z * z));
      const Vec3 d{s * std::cos(ph), s * std::sin(ph), z};
      const Hit h = rt.shoot({0, 0, 0}, d);
      const bool out = h.kind == HitKind::None;
      escaped += out;
      if (!out) {
        // on the box's surface, the normal facing the centre
        CHECK(h.kind == HitKind::Ground);
        double on = 0;
        for (int i = 0; i < 3; ++i) {
          CHECK(std::abs(h.position[i]) <= 1 + 1e-6);
          on = std::max(on, std::abs(h.position[i]));
        }
        CHECK(on == Approx(1).margin(1e-6));
        CHECK(dot(h.normal, d) < 0);
      }
      // where the ray's line crosses the window's plane, if it goes that way
      const double along = d[a.axis] * a.side;
      bool through = false, near_edge = false;
      if (along > 0) {
        const double t = 1 / along, u = t * d[a.u], v = t * d[a.v];
        through = std::abs(u) < 0.5 && std::abs(v) < 0.5;
        near_edge = std::abs(std::abs(u) - 0.5) < 1e-6 || std::abs(std::abs(v) - 0.5) < 1e-6;
      }
      if (near_edge) continue;
      ++judged;
      mismatched += out != through;
    }
    CHECK(mismatched == 0);
    CHECK(judged >= n - 2);
    const double se = std::sqrt(share * (1 - share) / n);
    INFO("escaped " << escaped << " of " << n << ", expected share " << share << " +- " << se);
    CHECK(std::abs(double(escaped) / n - share) <= 3 * se);
  }
}

TEST_CASE("inside the room the floor replaces the ground and its albedo the ground's", "[room]") {
  const Config c = parse_config("table: " + tiny_table() +
                                    "\nfit:\nrender:\n  ground: {z: -0.06, albedo: 0.4}\n"
                                    "  room: {enabled: true, min: [-1.5, -1.5, -0.2], albedo: 0.6}\n",
                                "room.yaml");
  const RenderSettings s = parse_render(*c.render);
  REQUIRE(s.room.enabled);
  REQUIRE(s.ground.enabled);
  const TableBsdf bsdf(c.table);
  const RenderScene scene(s, bsdf, "room.yaml");
  CHECK(scene.view().ground_albedo == 0.6);
  CHECK_THAT(scene.describe(), Catch::Contains("in a room of 18 triangles") && Catch::Contains("+z wall"));
  // straight down beside the cloth: the floor at -0.2, not the ground plane at -0.06
  Ray r;
  r.org = {1.2, -1.2, 0.5};
  r.dir = {0, 0, -1};
  const Hit h = scene.view().tracer->intersect(r);
  REQUIRE(h.kind == HitKind::Ground);
  CHECK(h.position[2] == Approx(-0.2).margin(1e-6));
  CHECK(h.normal[2] == 1);
  // without the room: the ground plane at -0.06, its albedo
  const Config c2 = parse_config("table: " + tiny_table() + "\nfit:\nrender:\n  ground: {z: -0.06, albedo: 0.4}\n",
                                 "room.yaml");
  const RenderSettings s2 = parse_render(*c2.render);
  const RenderScene scene2(s2, bsdf, "room.yaml");
  CHECK(scene2.view().ground_albedo == 0.4);
  CHECK(scene2.room().triangles.empty());
  const Hit h2 = scene2.view().tracer->intersect(r);
  REQUIRE(h2.kind == HitKind::Ground);
  CHECK(h2.position[2] == Approx(-0.06).margin(1e-6));
}

TEST_CASE("bad room keys are rejected with one line naming the key", "[room]") {
  auto one_line = [](const std::string& e) { return e.find('\n') == std::string::npos; };
  const std::string albedo = room_error("  room: {albedo: 1.5}\n");
  CHECK_THAT(albedo, Catch::Contains("room.yaml: render.room.albedo (line 3)") && Catch::Contains("out of range [0, 1]"));
  CHECK(one_line(albedo));
  const std::string outside =
      room_error("  room: {enabled: true, window: \"+x\", window_min: [-2, 0.5], window_max: [0.5, 1.5]}\n");
  CHECK_THAT(outside, Catch::Contains("render.room.window_min") && Catch::Contains("not inside the +x wall"));
  CHECK(one_line(outside));
  const std::string above = room_error("  room: {window: \"+z\", window_min: [0, 0], window_max: [0.5, 1.6]}\n");
  CHECK_THAT(above, Catch::Contains("render.room.window_max") && Catch::Contains("not inside the +z wall"));
  const std::string camera = room_error("  camera: {position: [0, -2, 1]}\n  room: {enabled: true}\n");
  CHECK_THAT(camera, Catch::Contains("room.yaml: render.camera.position") && Catch::Contains("not inside render.room"));
  CHECK(one_line(camera));
  // a disabled room does not hold the camera
  CHECK(room_error("  camera: {position: [0, -2, 1]}\n  room: {enabled: false}\n") == "no error");
  CHECK_THAT(room_error("  room: {window: \"-z\"}\n"),
             Catch::Contains("render.room.window (line 3)") && Catch::Contains("+x, -x, +y, -y or +z"));
  CHECK_THAT(room_error("  room: {min: [0, 0, 0], max: [1, 0, 1]}\n"),
             Catch::Contains("render.room.max") && Catch::Contains("larger than min"));
  CHECK_THAT(room_error("  room: {window_min: [1, 1], window_max: [1, 1.2]}\n"),
             Catch::Contains("render.room.window_max") && Catch::Contains("larger than window_min"));
  CHECK_THAT(room_error("  room: {min: [0, 0]}\n"), Catch::Contains("render.room.min") && Catch::Contains("three numbers"));
  CHECK_THAT(room_error("  room: {windw: \"+x\"}\n"), Catch::Contains("render.room.windw") && Catch::Contains("unknown key"));
  CHECK(room_error("  room: {enabled: true}\n") == "no error");  // the defaults hold the default camera
}
