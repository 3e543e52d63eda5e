// Parsing the `render` section.
#include "render/render_settings.hpp"

#include <cmath>
#include <set>

#include "config/node.hpp"
#include "scene/scene.hpp"
#include "core/error.hpp"

namespace bsdfmix {
namespace render {

namespace {

PathEstimator parse_estimator_name(const ConfigNode& n, const std::string& key, const std::string& name) {
  const EstimatorInfo* e = find_estimator(name);
  if (e == nullptr || !e->render.renders)
    n.fail(key, "unknown estimator '" + name + "' (expected " + path_estimator_list() + ")");
  return e->id;
}

// A nested mapping with its defaults merged under it and unknown keys rejected.
ConfigNode nested(const RenderSection& s, const ConfigNode& parent, const std::string& key) {
  YAML::Node user = parent.raw(key);
  const YAML::Node def = s.defaults[key];
  if (user && !user.IsNull() && !user.IsMap()) parent.fail(key, "expected a mapping");
  YAML::Node out = YAML::Clone(def);
  std::set<std::string> known;
  for (const auto& kv : def) known.insert(kv.first.Scalar());
  if (user && user.IsMap()) {
    ConfigNode(parent.file(), parent.path() + "." + key, user).reject_unknown(known);
    for (const auto& kv : user) out[kv.first.Scalar()] = kv.second;
  }
  return ConfigNode(parent.file(), parent.path() + "." + key, out);
}

Vec3 vec3(const ConfigNode& n, const std::string& key) {
  const std::vector<double> v = n.numbers(key, 3, "three numbers [x, y, z]");
  return {v[0], v[1], v[2]};
}

// guided, guided_product: the `guide` mapping (docs/render.md, "Guided paths").
void parse_guide(const ConfigNode& gd, RenderSettings& r) {
  r.guide.share = gd.number("share", 0, 1);
  if (!(r.guide.share > 0 && r.guide.share < 1))
    gd.fail("share", "expected a share strictly between 0 and 1 (the rest of the directions go to the BSDF sampler)");
  r.guide_iterations = int(gd.integer("iterations", 0, 20));
  r.guide_depth = int(gd.integer("depth", 1, 1000));
  r.guide_k_max = int(gd.integer("k_max", 1, 64));
  r.guide.leaf_samples = std::size_t(gd.integer("leaf_vertices", 16, INT64_MAX));
  r.guide.min_vertices = std::size_t(gd.integer("min_vertices", 1, INT64_MAX));
  const char* grid_shape = "[theta cells, phi cells], integers in [2, 256] and [2, 512]";
  const std::vector<double> grid = gd.numbers("grid", 2, grid_shape);
  if (!(grid[0] >= 2 && grid[0] <= 256 && grid[1] >= 2 && grid[1] <= 512) ||
      grid[0] != std::floor(grid[0]) || grid[1] != std::floor(grid[1]))
    gd.fail("grid", std::string("expected ") + grid_shape);
  r.guide.grid_theta = int(grid[0]);
  r.guide.grid_phi = int(grid[1]);
}

void parse_cloth(const ConfigNode& cl, ClothParams& c) {
  c.weave = cl.str("weave");
  c.size = cl.number("size", 1e-9, 1e9);
  c.yarn_spacing = cl.number("yarn_spacing", 1e-9, 1e9);
  c.yarn_radius = cl.number("yarn_radius", 1e-9, 1e9);
  c.plies = int(cl.integer("plies", 1, 64));
  c.ply_twist = cl.number("ply_twist", -1e6, 1e6);
  c.fibers_per_ply = int(cl.integer("fibers_per_ply", 1, 10000));
  c.fiber_twist = cl.number("fiber_twist", -1e6, 1e6);
  c.fiber_radius = cl.number("fiber_radius", 1e-12, 1e9);
  c.jitter = cl.number("jitter", 0, 1);
  c.segments_per_spacing = int(cl.integer("segments_per_spacing", 1, 1000));
  c.seed = std::uint64_t(cl.integer("seed", 0, INT64_MAX));
  c.drape = cl.str("drape");
  c.drape_radius = cl.number("drape_radius", 1e-9, 1e9);
}

// The lighting, in world space: the `scene` (a file or a mapping), else a constant 1.
Lighting parse_lighting(const RenderSection& section, const ConfigNode& n) {
  Lighting l = default_lighting(Domain::Hemisphere, 1.0);
  l.name = "constant";
  if (n.has("scene")) {
    const YAML::Node sc = n.raw("scene");
    if (sc.IsScalar()) {
      const std::string path = sc.Scalar();
      if (!exists_quiet(path)) n.fail("scene", path + ": no such file");
      l = parse_scene(YAML::LoadFile(path), path, "", Domain::Hemisphere);
    } else if (sc.IsMap()) {
      l = parse_scene(sc, section.file, "render.scene", Domain::Hemisphere);
    } else {
      n.fail("scene", "expected a scene file or an inline scene mapping");
    }
  }
  return l;
}

}  // namespace

RenderSettings render_settings(const Config& config) {
  if (!config.render) throw ConfigError(config.file + ": render: missing (the render command needs a render section)");
  if (!config.fit) throw ConfigError(config.file + ": fit: missing (the render fits the mixtures the scene needs)");
  RenderSettings s = parse_render(*config.render);
  // is_rgl and mis_light_rgl sample with the warps of the RGL file the table came from
  std::vector<PathEstimator> all = s.estimators;
  all.push_back(s.reference_estimator);
  if (s.stand_in) all.push_back(s.stand_in_estimator);
  for (const PathEstimator e : all)
    if (uses_rgl(e) && !(config.import && !config.import->rgl.empty()))
      throw ConfigError(config.file + ": render: estimator '" + path_estimator_name(e) +
                        "' samples with an RGL file's own warps and needs a measured surface imported from one "
                        "(import.rgl); this config's table '" + config.table + "' is not");
  return s;
}

RenderSettings parse_render(const RenderSection& section) {
  const ConfigNode n(section.file, "render", section.node);
  RenderSettings r;
  r.file = section.file;
  r.output = n.str("output");
  r.summary_figure = n.str("summary_figure");
  if (r.summary_figure.empty()) n.fail("summary_figure", "expected a file name (relative to output)");
  r.width = int(n.integer("width", 1, 16384));
  r.height = int(n.integer("height", 1, 16384));
  r.spp = int(n.integer("spp", 1, 1 << 20));
  r.seconds = n.number("seconds", 0, 1e7);
  r.reference_spp = int(n.integer("reference_spp", 1, 1 << 24));
  r.reference_estimator = parse_estimator_name(n, "reference_estimator", n.str("reference_estimator"));
  const YAML::Node est = n.raw("estimators");
  if (!est.IsSequence() || est.size() == 0) n.fail("estimators", "expected a list of estimator names");
  for (const auto& e : est) {
    if (!e.IsScalar()) n.fail("estimators", "expected a list of estimator names");
    r.estimators.push_back(parse_estimator_name(n, "estimators", e.Scalar()));
  }
  r.stand_in = n.boolean("stand_in");
  r.stand_in_spp = int(n.integer("stand_in_spp", 1, 1 << 20));
  r.stand_in_estimator = parse_estimator_name(n, "stand_in_estimator", n.str("stand_in_estimator"));
  r.product_share = n.number("product_share", 0, 1);
  if (!(r.product_share > 0 && r.product_share < 1))
    n.fail("product_share", "expected a share strictly between 0 and 1 (the rest of the light samples go to the light sampler)");
  for (const auto& [key, e] : {std::pair<const char*, PathEstimator>{"reference_estimator", r.reference_estimator},
                                {"stand_in_estimator", r.stand_in_estimator}})
    if (is_guided(e)) n.fail(key, "a guided estimator learns within each render; expected one that does not");
  parse_guide(nested(section, n, "guide"), r);
  r.max_depth = int(n.integer("max_depth", 1, 1000));
  r.rr_depth = int(n.integer("rr_depth", 1, 1000));
  r.seed = std::uint64_t(n.integer("seed", 0, INT64_MAX));
  r.threads = int(n.integer("threads", 0, 4096));
  r.prepass = int(n.integer("prepass", 4, 4096));
  // 0: every vertex a path can reach, so that the stand-in has every slice its paths use
  r.prepass_depth = int(n.integer("prepass_depth", 0, 1000));
  if (r.prepass_depth == 0) r.prepass_depth = r.max_depth;

  r.lighting = parse_lighting(section, n);

  const ConfigNode cam = nested(section, n, "camera");
  r.camera.position = vec3(cam, "position");
  r.camera.look_at = vec3(cam, "look_at");
  r.camera.up = vec3(cam, "up");
  r.camera.fov_deg = cam.number("fov_deg", 1, 170);

  parse_cloth(nested(section, n, "cloth"), r.cloth);

  const ConfigNode g = nested(section, n, "ground");
  r.ground.enabled = g.boolean("enabled");
  r.ground.z = g.number("z", -1e9, 1e9);
  r.ground_albedo = g.number("albedo", 0, 1);

  const ConfigNode sp = nested(section, n, "sphere");
  r.sphere_center = vec3(sp, "center");
  r.sphere_radius = sp.number("radius", 1e-9, 1e9);
  r.sphere_rings = int(sp.integer("rings", 3, 4096));
  r.sphere_segments = int(sp.integer("segments", 3, 4096));
  r.room = parse_room(nested(section, n, "room"), r.camera.position);
  if (n.has("table_4d")) r.table_4d = n.str("table_4d");
  if (n.has("mixture_4d")) r.mixture_4d = n.str("mixture_4d");
  if (r.table_4d.empty() != r.mixture_4d.empty())
    n.fail(r.table_4d.empty() ? "table_4d" : "mixture_4d", "table_4d and mixture_4d go together (the table, its stand-in)");
  return r;
}

}  // namespace render
}  // namespace bsdfmix
