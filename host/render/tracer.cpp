// Embree scene of the cloth: one curve geometry holding every fiber (geometry 0), the ground
// quad as two triangles (geometry 1), the surface (2), the room (3), and the self-hit filter
// on the curves.
#include "render/tracer.hpp"

#include <embree3/rtcore.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "core/error.hpp"

namespace bsdfmix {
namespace render {

namespace {

constexpr unsigned kCurveGeom = 0, kGroundGeom = 1, kSurfaceGeom = 2, kRoomGeom = 3;

// The intersect context extended with the ray's self-hit rule. Embree passes the context
// pointer through to the filter, which casts it back (the base must be the first member).
struct Context {
  RTCIntersectContext base;
  std::int64_t from_fiber;
  float skip;
  const std::int32_t* fiber_of;  // segment (primID) -> fiber
};

// Filter on the curve geometry, for both intersect and occluded: reject hits on the fiber
// the ray leaves closer than `skip`. Embree has put the hit's distance into the ray's tfar.
// (Embree also culls, by itself, flat-curve hits within 2 radii of the ray's origin on any
// fiber: its build option EMBREE_CURVE_SELF_INTERSECTION_AVOIDANCE_FACTOR, default 2.)
void self_hit_filter(const RTCFilterFunctionNArguments* args) {
  const Context* c = reinterpret_cast<const Context*>(args->context);
  if (c->from_fiber < 0) return;
  for (unsigned i = 0; i < args->N; ++i) {
    if (args->valid[i] != -1) continue;
    const unsigned prim = RTCHitN_primID(args->hit, args->N, i);
    if (c->fiber_of[prim] == c->from_fiber && RTCRayN_tfar(args->ray, args->N, i) < c->skip) args->valid[i] = 0;
  }
}

const char* error_name(RTCError e) {
  switch (e) {
    case RTC_ERROR_NONE: return "no error";
    case RTC_ERROR_UNKNOWN: return "unknown error";
    case RTC_ERROR_INVALID_ARGUMENT: return "invalid argument";
    case RTC_ERROR_INVALID_OPERATION: return "invalid operation";
    case RTC_ERROR_OUT_OF_MEMORY: return "out of memory";
    case RTC_ERROR_UNSUPPORTED_CPU: return "unsupported CPU";
    case RTC_ERROR_CANCELLED: return "cancelled";
  }
  return "unknown error";
}

// Embree reports the message of an error only through this callback; keep the last one.
void remember_error(void* user, RTCError, const char* str) { *static_cast<std::string*>(user) = str ? str : ""; }

}  // namespace

struct Tracer::Impl {
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
  std::string last_error;
  CurveType type = CurveType::FlatLinear;
  bool ground = false;
  double ground_z = 0;
  std::vector<std::int32_t> fiber_of;  // segment (primID) -> fiber
  SurfaceMesh surface;                 // the surface's triangles and shading normals (a copy)
  std::vector<Vec3> room_normal;       // per room triangle: unit geometric normal ...
  std::vector<Vec3> room_point;        // ... and its first vertex, as Embree holds it (floats)
  const float* vertices = nullptr;     // the curve geometry's vertex buffer (x, y, z, r)
  const unsigned* indices = nullptr;   // the curve geometry's index buffer

  // Throws with Embree's error text if the last calls failed.
  void check(const std::string& what) {
    const RTCError e = rtcGetDeviceError(device);
    if (e != RTC_ERROR_NONE)
      throw Error("render: Embree failed to " + what + ": " + error_name(e) +
                  (last_error.empty() ? "" : " (" + last_error + ")"));
  }

  // A triangle mesh as the scene's geometry `id`, its vertices as float; Error naming
  // `what` for a triangle that indexes past the vertices.
  void attach_mesh(const SurfaceMesh& mesh, unsigned id, const std::string& what) {
    RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
    float* vb = static_cast<float*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                             3 * sizeof(float), mesh.vertices.size()));
    unsigned* ib = static_cast<unsigned*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                                   3 * sizeof(unsigned), mesh.triangles.size()));
    check("allocate the " + what + " buffers");
    for (std::size_t i = 0; i < mesh.vertices.size(); ++i)
      for (int c = 0; c < 3; ++c) vb[3 * i + std::size_t(c)] = static_cast<float>(mesh.vertices[i][c]);
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t)
      for (int c = 0; c < 3; ++c) {
        if (mesh.triangles[t][std::size_t(c)] >= mesh.vertices.size())
          throw Error("render: a " + what + " triangle is out of range");
        ib[3 * t + std::size_t(c)] = mesh.triangles[t][std::size_t(c)];
      }
    rtcCommitGeometry(g);
    rtcAttachGeometryByID(scene, g, id);
    rtcReleaseGeometry(g);
    check("build the " + what + " geometry");
  }

  bool bspline() const { return type == CurveType::FlatBSpline || type == CurveType::RoundBSpline; }

  // Unit tangent of segment `prim` at curve parameter u (in [0, 1]).
  Vec3 tangent(unsigned prim, float u) const {
    const float* p = vertices + 4 * static_cast<std::size_t>(indices[prim]);
    if (!bspline()) return normalized({p[4] - p[0], p[5] - p[1], p[6] - p[2]});
    // Derivative of the uniform cubic B-spline basis over the four control points.
    const double v = u, w[4] = {-(1 - v) * (1 - v) / 2, (3 * v * v - 4 * v) / 2, (-3 * v * v + 2 * v + 1) / 2, v * v / 2};
    Vec3 d{0, 0, 0};
    for (int k = 0; k < 4; ++k)
      for (int c = 0; c < 3; ++c) d[c] += w[k] * p[4 * k + c];
    return normalized(d);
  }

  // The Embree device (its default configuration: its own worker threads for the build)
  // and an empty scene. Embree's builders are deterministic for a given input except in
  // high-quality (spatial split) mode, so the scene keeps the medium build quality.
  void create_scene() {
    device = rtcNewDevice(nullptr);
    if (!device) throw Error(std::string("render: cannot create an Embree device: ") + error_name(rtcGetDeviceError(nullptr)));
    rtcSetDeviceErrorFunction(device, remember_error, &last_error);
    if (!rtcGetDeviceProperty(device, RTC_DEVICE_PROPERTY_FILTER_FUNCTION_SUPPORTED))
      throw Error("render: this Embree build has no filter functions (EMBREE_FILTER_FUNCTION), needed against self-hits");
    scene = rtcNewScene(device);
    rtcSetSceneBuildQuality(scene, RTC_BUILD_QUALITY_MEDIUM);
    check("create the scene");
  }

  // Every fiber of `cloth` as one curve geometry (kCurveGeom), with the self-hit filter.
  // Linear: a fiber of n points is n - 1 segments, each indexed by its first vertex.
  // B-spline: the points are the control points, with a phantom point mirrored past each
  // end (2 p0 - p1) so the curve starts and ends exactly at the end points, with a nonzero
  // tangent there; n - 1 windows of four control points.
  void attach_curves(const Cloth& cloth) {
    std::size_t vertex_count = 0, segment_count = 0;
    for (std::size_t f = 0; f < cloth.fibers.size(); ++f) {
      const std::size_t n = cloth.fibers[f].points.size();
      if (n < 2)
        throw Error("render: fiber " + std::to_string(f) + " has " + std::to_string(n) + " point(s), a curve needs 2");
      vertex_count += bspline() ? n + 2 : n;
      segment_count += n - 1;
    }
    if (vertex_count > std::numeric_limits<std::int32_t>::max() ||
        cloth.fibers.size() > static_cast<std::size_t>(std::numeric_limits<std::int32_t>::max()))
      throw Error("render: the cloth has too many fibers or points for one Embree geometry");
    if (segment_count == 0) return;

    static const RTCGeometryType kTypes[] = {RTC_GEOMETRY_TYPE_FLAT_LINEAR_CURVE, RTC_GEOMETRY_TYPE_ROUND_LINEAR_CURVE,
                                             RTC_GEOMETRY_TYPE_FLAT_BSPLINE_CURVE, RTC_GEOMETRY_TYPE_ROUND_BSPLINE_CURVE};
    RTCGeometry g = rtcNewGeometry(device, kTypes[static_cast<int>(type)]);
    float* vb = static_cast<float*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT4,
                                                             4 * sizeof(float), vertex_count));
    unsigned* ib = static_cast<unsigned*>(
        rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT, sizeof(unsigned), segment_count));
    // Linear curves: flags telling Embree which segments continue a neighbour, so round
    // curves join without inner end caps.
    unsigned char* fb = bspline() ? nullptr
                                  : static_cast<unsigned char*>(rtcSetNewGeometryBuffer(
                                        g, RTC_BUFFER_TYPE_FLAGS, 0, RTC_FORMAT_UCHAR, 1, segment_count));
    check("allocate the curve buffers");
    fiber_of.resize(segment_count);

    std::size_t v = 0, s = 0;
    auto put = [&](const Vec3& p, double r) {
      float* o = vb + 4 * v++;
      o[0] = static_cast<float>(p[0]), o[1] = static_cast<float>(p[1]), o[2] = static_cast<float>(p[2]);
      o[3] = static_cast<float>(r);
    };
    for (std::size_t f = 0; f < cloth.fibers.size(); ++f) {
      const std::vector<Vec3>& pts = cloth.fibers[f].points;
      const double r = cloth.fibers[f].radius;
      const std::size_t n = pts.size(), first = v;
      if (bspline()) put(sub(pts[0], sub(pts[1], pts[0])), r);
      for (const Vec3& p : pts) put(p, r);
      if (bspline()) put(sub(pts[n - 1], sub(pts[n - 2], pts[n - 1])), r);
      for (std::size_t k = 0; k + 1 < n; ++k, ++s) {
        ib[s] = static_cast<unsigned>(first + k);
        fiber_of[s] = static_cast<std::int32_t>(f);
        if (fb) fb[s] = (k > 0 ? RTC_CURVE_FLAG_NEIGHBOR_LEFT : 0) | (k + 2 < n ? RTC_CURVE_FLAG_NEIGHBOR_RIGHT : 0);
      }
    }
    vertices = vb;
    indices = ib;
    rtcSetGeometryIntersectFilterFunction(g, self_hit_filter);
    rtcSetGeometryOccludedFilterFunction(g, self_hit_filter);
    rtcCommitGeometry(g);
    rtcAttachGeometryByID(scene, g, kCurveGeom);
    rtcReleaseGeometry(g);  // the scene holds it (and its buffers) from here
    check("build the curve geometry");
  }

  // The ground square as two triangles (kGroundGeom).
  void attach_ground(const GroundPlane& plane) {
    ground = true;
    ground_z = plane.z;
    RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
    float* vb = static_cast<float*>(
        rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), 4));
    unsigned* ib = static_cast<unsigned*>(
        rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), 2));
    check("allocate the ground buffers");
    const float h = static_cast<float>(plane.half), z = static_cast<float>(plane.z);
    const float corners[12] = {-h, -h, z, h, -h, z, h, h, z, -h, h, z};
    std::copy(corners, corners + 12, vb);
    const unsigned tris[6] = {0, 1, 2, 0, 2, 3};
    std::copy(tris, tris + 6, ib);
    rtcCommitGeometry(g);
    rtcAttachGeometryByID(scene, g, kGroundGeom);
    rtcReleaseGeometry(g);
    check("build the ground geometry");
  }

  // The room's triangles (kRoomGeom), and each one's unit normal and first vertex, from
  // the float vertices Embree holds.
  void attach_room(const SurfaceMesh& room) {
    attach_mesh(room, kRoomGeom, "room");
    for (const auto& tri : room.triangles) {
      Vec3 p[3];
      for (int c = 0; c < 3; ++c)
        for (int d = 0; d < 3; ++d) p[c][d] = static_cast<float>(room.vertices[tri[std::size_t(c)]][d]);
      const Vec3 n = cross(sub(p[1], p[0]), sub(p[2], p[0]));
      if (!(dot(n, n) > 0)) throw Error("render: a room triangle has no area");
      room_normal.push_back(normalized(n));
      room_point.push_back(p[0]);
    }
  }

  ~Impl() {
    if (scene) rtcReleaseScene(scene);
    if (device) rtcReleaseDevice(device);
  }
};

Tracer::Tracer(const Cloth& cloth, const GroundPlane& ground, CurveType type, const SurfaceMesh* surface,
               const SurfaceMesh* room)
    : impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  m.type = type;
  m.create_scene();
  m.attach_curves(cloth);
  if (ground.enabled) m.attach_ground(ground);
  if (surface && !surface->triangles.empty()) {
    m.surface = *surface;
    if (m.surface.normals.size() != m.surface.vertices.size())
      throw Error("render: the surface needs one normal per vertex");
    m.attach_mesh(m.surface, kSurfaceGeom, "surface");
  }
  if (room && !room->triangles.empty()) m.attach_room(*room);
  rtcCommitScene(m.scene);
  m.check("commit the scene");
}

Tracer::~Tracer() = default;

namespace {

// The Embree ray of `ray` (floats) and the filter's context.
void to_embree(const Ray& ray, const std::vector<std::int32_t>& fiber_of, RTCRay& r, Context& c) {
  r.org_x = static_cast<float>(ray.org[0]), r.org_y = static_cast<float>(ray.org[1]);
  r.org_z = static_cast<float>(ray.org[2]);
  r.dir_x = static_cast<float>(ray.dir[0]), r.dir_y = static_cast<float>(ray.dir[1]);
  r.dir_z = static_cast<float>(ray.dir[2]);
  r.tnear = static_cast<float>(ray.tnear);
  r.tfar = static_cast<float>(std::min(ray.tfar, 3e38));
  r.time = 0;
  r.mask = 0xFFFFFFFFu;
  r.id = 0;
  r.flags = 0;
  rtcInitIntersectContext(&c.base);
  c.from_fiber = ray.from_fiber;
  c.skip = static_cast<float>(ray.skip);
  c.fiber_of = fiber_of.data();
}

}  // namespace

Hit Tracer::intersect(const Ray& ray) const {
  const Impl& m = *impl_;
  RTCRayHit rh;
  Context c;
  to_embree(ray, m.fiber_of, rh.ray, c);
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.primID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(m.scene, &c.base, &rh);

  Hit h;
  if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return h;
  h.t = rh.ray.tfar;
  for (int d = 0; d < 3; ++d) h.position[d] = ray.org[d] + h.t * ray.dir[d];
  if (rh.hit.geomID == kCurveGeom) {
    h.kind = HitKind::Fiber;
    h.fiber = m.fiber_of[rh.hit.primID];
    h.tangent = m.tangent(rh.hit.primID, rh.hit.u);
  } else if (rh.hit.geomID == kSurfaceGeom) {
    h.kind = HitKind::Surface;
    const auto& tri = m.surface.triangles[rh.hit.primID];
    const double u = rh.hit.u, v = rh.hit.v;
    Vec3 n{0, 0, 0};
    for (int k = 0; k < 3; ++k)
      n[k] = (1 - u - v) * m.surface.normals[tri[0]][k] + u * m.surface.normals[tri[1]][k] +
             v * m.surface.normals[tri[2]][k];
    n = normalized(n);
    if (dot(n, ray.dir) > 0) n = neg(n);  // the side the ray comes from
    h.normal = n;
  } else if (rh.hit.geomID == kRoomGeom) {
    // A wall, the floor or the ceiling: diffuse like the ground. The position is moved onto
    // the triangle's plane (exactly, for the room's axis-aligned walls), so that a ray
    // leaving it neither starts behind the wall nor hits it again.
    h.kind = HitKind::Ground;
    Vec3 n = m.room_normal[rh.hit.primID];
    if (dot(n, ray.dir) > 0) n = neg(n);  // the side the ray comes from
    const double off = dot(sub(h.position, m.room_point[rh.hit.primID]), n);
    for (int d = 0; d < 3; ++d) h.position[d] -= off * n[d];
    h.normal = n;
  } else {
    h.kind = HitKind::Ground;
    h.normal = {0, 0, ray.org[2] >= m.ground_z ? 1.0 : -1.0};  // the side the ray comes from
  }
  return h;
}

bool Tracer::occluded(const Ray& ray) const {
  const Impl& m = *impl_;
  RTCRay r;
  Context c;
  to_embree(ray, m.fiber_of, r, c);
  rtcOccluded1(m.scene, &c.base, &r);
  return r.tfar < 0;  // Embree sets tfar to -inf when it finds an occluder
}

}  // namespace render
}  // namespace bsdfmix
