// The room (docs/render.md, "The room"): a closed box of diffuse walls, floor and ceiling
// around the cloth or the sphere, open to the scene's distant lighting through one window,
// so that most light reaching the material has bounced off the walls first.
#pragma once

#include <string>

#include "config/node.hpp"
#include "core/vec3.hpp"
#include "render/surface.hpp"

namespace bsdfmix {
namespace render {

// The window is a rectangle on one wall, in the wall's own coordinates (u, v): the two
// world axes other than the wall's normal axis, in order (x, y, z): the +x and -x walls
// have (y, z), the +y and -y walls (x, z), the ceiling (+z) (x, y). The floor has no window.
struct RoomParams {
  bool enabled = false;
  Vec3 min{-1.5, -1.5, -0.06}, max{1.5, 1.5, 1.8};  // the box's corners; min's z is the floor
  double albedo = 0.5;                               // every wall, the floor and the ceiling
  std::string window = "+z";                          // +x, -x, +y, -y or +z
  double window_min[2] = {0.9, 1.05}, window_max[2] = {1.45, 1.45};  // (u, v) corners
};

// The `render.room` mapping (defaults merged): one-line ConfigErrors naming the key for a
// degenerate box, an unknown wall, a window of no area or outside its wall, an albedo
// outside [0, 1], and (when the room is enabled) a camera outside the box, named as
// render.camera.position.
RoomParams parse_room(const ConfigNode& room, const Vec3& camera_position);

// The room's triangles with their inward unit normals: the floor, the ceiling and four
// walls, two triangles each, but the window's wall, which is up to four rectangles around
// the hole. Empty when the room is disabled.
SurfaceMesh make_room(const RoomParams& p);

// The window's wall as an axis (0, 1, 2) and a side (+1: the max face, -1: the min face),
// and the two axes (u, v) of its coordinates.
struct WallAxes {
  int axis = 2, side = 1, u = 0, v = 1;
};
WallAxes window_wall(const std::string& window);

}  // namespace render
}  // namespace bsdfmix
