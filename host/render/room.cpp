// The room: its config and its triangles.
#include "render/room.hpp"

#include <vector>

#include "core/error.hpp"
#include "core/format.hpp"

namespace bsdfmix {
namespace render {

namespace {

// The walls a window may be on (not the floor, -z).
bool window_wall_name(const std::string& w) {
  for (const char* k : {"+x", "-x", "+y", "-y", "+z"})
    if (w == k) return true;
  return false;
}

std::string show(double x) { return format_number(x, "%g"); }

// Appends the rectangle [u0, u1] x [v0, v1] of wall `a`, on the plane at `w` along its
// axis, as two triangles with the unit normal `sign` times the axis; nothing when it has no
// area.
void add_rect(SurfaceMesh& m, const WallAxes& a, double w, double u0, double u1, double v0, double v1, double sign) {
  if (!(u1 > u0) || !(v1 > v0)) return;
  const unsigned first = unsigned(m.vertices.size());
  const double uv[4][2] = {{u0, v0}, {u1, v0}, {u1, v1}, {u0, v1}};
  Vec3 n{0, 0, 0};
  n[a.axis] = sign;
  for (const auto& c : uv) {
    Vec3 p{0, 0, 0};
    p[a.axis] = w, p[a.u] = c[0], p[a.v] = c[1];
    m.vertices.push_back(p);
    m.normals.push_back(n);
  }
  m.triangles.push_back({first, first + 1, first + 2});
  m.triangles.push_back({first, first + 2, first + 3});
}

// The wall normal to `axis` on its `side`, with its (u, v) axes.
WallAxes wall_axes(int axis, int side) {
  WallAxes a;
  a.axis = axis;
  a.side = side;
  a.u = axis == 0 ? 1 : 0;
  a.v = axis == 2 ? 1 : 2;
  return a;
}

}  // namespace

WallAxes window_wall(const std::string& window) {
  if (!window_wall_name(window))
    throw Error("render: room window wall '" + window + "' is not one of +x, -x, +y, -y, +z");
  return wall_axes(window[1] - 'x', window[0] == '+' ? 1 : -1);
}

RoomParams parse_room(const ConfigNode& room, const Vec3& camera_position) {
  RoomParams p;
  p.enabled = room.boolean("enabled");
  const std::vector<double> lo = room.numbers("min", 3, "three numbers [x, y, z]");
  const std::vector<double> hi = room.numbers("max", 3, "three numbers [x, y, z]");
  for (int i = 0; i < 3; ++i) {
    p.min[i] = lo[std::size_t(i)];
    p.max[i] = hi[std::size_t(i)];
    if (!(p.max[i] > p.min[i])) room.fail("max", "the box must be larger than min along every axis");
  }
  p.albedo = room.number("albedo", 0, 1);
  p.window = room.str("window");
  if (!window_wall_name(p.window))
    room.fail("window", "expected +x, -x, +y, -y or +z (the wall with the window), not '" + p.window + "'");
  const WallAxes a = window_wall(p.window);
  const std::vector<double> wlo = room.numbers("window_min", 2, "two numbers [u, v]");
  const std::vector<double> whi = room.numbers("window_max", 2, "two numbers [u, v]");
  for (int k = 0; k < 2; ++k) {
    p.window_min[k] = wlo[std::size_t(k)];
    p.window_max[k] = whi[std::size_t(k)];
    if (!(p.window_max[k] > p.window_min[k]))
      room.fail("window_max", "the window must be larger than window_min in u and v");
  }
  const int ax[2] = {a.u, a.v};
  for (int k = 0; k < 2; ++k) {
    const bool below = p.window_min[k] < p.min[ax[k]];
    if (below || p.window_max[k] > p.max[ax[k]])
      room.fail(below ? "window_min" : "window_max",
                "the window [" + show(p.window_min[0]) + ", " + show(p.window_min[1]) + "] to [" +
                    show(p.window_max[0]) + ", " + show(p.window_max[1]) + "] is not inside the " + p.window +
                    " wall (" + "xyz"[a.u] + " in [" + show(p.min[a.u]) + ", " + show(p.max[a.u]) + "], " + "xyz"[a.v] +
                    " in [" + show(p.min[a.v]) + ", " + show(p.max[a.v]) + "])");
  }
  if (p.enabled)
    for (int i = 0; i < 3; ++i)
      if (!(camera_position[i] > p.min[i] && camera_position[i] < p.max[i])) {
        const std::string parent = room.path().substr(0, room.path().rfind('.'));
        throw ConfigError(room.file() + ": " + parent + ".camera.position: the camera [" + show(camera_position[0]) +
                          ", " + show(camera_position[1]) + ", " + show(camera_position[2]) + "] is not inside " +
                          room.path() + "'s box");
      }
  return p;
}

SurfaceMesh make_room(const RoomParams& p) {
  SurfaceMesh m;
  if (!p.enabled) return m;
  const WallAxes win = window_wall(p.window);
  for (int axis = 0; axis < 3; ++axis)
    for (int side = -1; side <= 1; side += 2) {
      const WallAxes a = wall_axes(axis, side);
      const double w = side > 0 ? p.max[axis] : p.min[axis];
      const double u0 = p.min[a.u], u1 = p.max[a.u], v0 = p.min[a.v], v1 = p.max[a.v];
      const double inward = -side;
      if (axis != win.axis || side != win.side) {
        add_rect(m, a, w, u0, u1, v0, v1, inward);
        continue;
      }
      const double wu0 = p.window_min[0], wu1 = p.window_max[0], wv0 = p.window_min[1], wv1 = p.window_max[1];
      add_rect(m, a, w, u0, u1, v0, wv0, inward);    // below the window (in v)
      add_rect(m, a, w, u0, u1, wv1, v1, inward);    // above
      add_rect(m, a, w, u0, wu0, wv0, wv1, inward);  // beside, at low u
      add_rect(m, a, w, wu1, u1, wv0, wv1, inward);  // beside, at high u
    }
  return m;
}

}  // namespace render
}  // namespace bsdfmix
