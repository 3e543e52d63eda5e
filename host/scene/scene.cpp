// Scenes of the convergence study and the renderer: YAML parsing with errors naming file and key.
#include "scene/scene.hpp"

#include <cmath>
#include <filesystem>
#include <set>

#include "core/error.hpp"
#include "core/suggest.hpp"
#include "io/pfm.hpp"

namespace bsdfmix {

namespace {

struct Ctx {
  std::string file, where;
  [[noreturn]] void fail(const std::string& key, const YAML::Node& n, const std::string& problem) const {
    std::string at = file + ": " + (where.empty() ? "" : where + ".") + key;
    if (n && n.Mark().line >= 0) at += " (line " + std::to_string(n.Mark().line + 1) + ")";
    throw ConfigError(at + ": " + problem);
  }
};

void check_keys(const Ctx& c, const std::string& path, const YAML::Node& n, const std::set<std::string>& known) {
  if (!n.IsMap()) c.fail(path, n, "expected a mapping");
  for (const auto& kv : n) {
    const std::string k = kv.first.Scalar();
    if (!known.count(k)) {
      std::string list;
      for (const auto& s : known) list += (list.empty() ? "" : ", ") + s;
      const std::string guess = closest_name(k, std::vector<std::string>(known.begin(), known.end()));
      c.fail(path.empty() ? k : path + "." + k, kv.first,
             "unknown key" + (guess.empty() ? "" : "; did you mean '" + guess + "'?") + " (known: " + list + ")");
    }
  }
}

double number(const Ctx& c, const std::string& key, const YAML::Node& n, double lo, double hi) {
  double v = 0;
  try {
    if (!n.IsScalar()) throw YAML::Exception(n.Mark(), "");
    v = n.as<double>();
  } catch (const YAML::Exception&) {
    c.fail(key, n, "expected a number");
  }
  if (!(v >= lo && v <= hi) || !std::isfinite(v))
    c.fail(key, n, std::to_string(v) + " is out of range [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
  return v;
}

Vec3 vec3(const Ctx& c, const std::string& key, const YAML::Node& n, bool unit) {
  if (!n.IsSequence() || n.size() != 3) c.fail(key, n, "expected a 3-vector [x, y, z]");
  Vec3 v;
  for (std::size_t i = 0; i < 3; ++i) v[i] = number(c, key, n[i], -1e9, 1e9);
  if (unit) {
    const double l = std::sqrt(dot(v, v));
    if (!(l > 1e-9)) c.fail(key, n, "the vector is zero");
    for (auto& x : v) x /= l;
  }
  return v;
}

}  // namespace

Lighting parse_scene(const YAML::Node& node, const std::string& file, const std::string& where, Domain domain) {
  const Ctx c{file, where};
  if (!node || !node.IsMap()) c.fail("scene", node, "expected a scene mapping");
  check_keys(c, "", node, {"name", "frame", "constant", "lobes", "gradient", "envmap"});
  Lighting l = default_lighting(domain, 0.0);
  l.name = node["name"] ? node["name"].Scalar()
                        : (file.empty() ? "scene" : std::filesystem::path(file).stem().string());
  if (l.name.empty() || l.name.find_first_of(",\"\n") != std::string::npos)
    c.fail("name", node["name"], "a scene name must be non-empty without commas or quotes");
  if (const YAML::Node fr = node["frame"]) {
    check_keys(c, "frame", fr, {"tangent", "normal"});
    const bool fiber = domain == Domain::Fiber;
    Vec3 tangent = fiber ? Vec3{1, 0, 0} : Vec3{1, 0, 0}, normal = fiber ? Vec3{0, 0, 1} : Vec3{0, 0, 1};
    if (fr["tangent"]) tangent = vec3(c, "frame.tangent", fr["tangent"], true);
    if (fr["normal"]) normal = vec3(c, "frame.normal", fr["normal"], true);
    const std::string at = file + ": " + (where.empty() ? "" : where + ".") + "frame";
    // fiber: the tangent is the axis and the normal gives phi = 0; hemisphere: the other way
    if (fiber) set_frame(l, tangent, normal, at);
    else set_frame(l, normal, tangent, at);
  }
  if (node["constant"]) l.constant = number(c, "constant", node["constant"], 0, 1e12);
  if (const YAML::Node lobes = node["lobes"]) {
    if (!lobes.IsSequence()) c.fail("lobes", lobes, "expected a list of lobes");
    if (lobes.size() > Lighting::kMaxLobes) c.fail("lobes", lobes, "at most 8 lobes");
    for (std::size_t i = 0; i < lobes.size(); ++i) {
      const std::string key = "lobes[" + std::to_string(i) + "]";
      const YAML::Node lb = lobes[i];
      check_keys(c, key, lb, {"direction", "radius_deg", "kappa", "radiance"});
      LightLobe lobe;
      if (!lb["direction"]) c.fail(key + ".direction", lb, "missing");
      lobe.direction = vec3(c, key + ".direction", lb["direction"], true);
      if (lb["radius_deg"] && lb["kappa"]) c.fail(key, lb, "give radius_deg or kappa, not both");
      if (lb["kappa"]) {
        lobe.kappa = number(c, key + ".kappa", lb["kappa"], 1e-6, 1e7);
      } else if (lb["radius_deg"]) {
        const double r = number(c, key + ".radius_deg", lb["radius_deg"], 0.05, 180) * kPi / 180;
        lobe.kappa = std::log(2.0) / (1 - std::cos(r));  // half maximum at the radius
      } else {
        c.fail(key, lb, "missing radius_deg (half-maximum radius) or kappa");
      }
      if (!lb["radiance"]) c.fail(key + ".radiance", lb, "missing");
      lobe.radiance = number(c, key + ".radiance", lb["radiance"], 0, 1e12);
      l.lobes.push_back(lobe);
    }
  }
  if (const YAML::Node g = node["gradient"]) {
    check_keys(c, "gradient", g, {"up", "zenith", "horizon", "ground"});
    l.gradient = true;
    if (g["up"]) l.up = vec3(c, "gradient.up", g["up"], true);
    for (const char* k : {"zenith", "horizon", "ground"})
      if (!g[k]) c.fail(std::string("gradient.") + k, g, "missing");
    l.zenith = number(c, "gradient.zenith", g["zenith"], 0, 1e12);
    l.horizon = number(c, "gradient.horizon", g["horizon"], 0, 1e12);
    l.ground = number(c, "gradient.ground", g["ground"], 0, 1e12);
  }
  if (const YAML::Node e = node["envmap"]) {
    check_keys(c, "envmap", e, {"file", "scale"});
    if (!e["file"] || !e["file"].IsScalar()) c.fail("envmap.file", e, "missing: name a lat-long PFM image");
    std::string path = e["file"].Scalar();
    if (!std::filesystem::exists(path) && !file.empty() && std::filesystem::path(path).is_relative()) {
      const auto beside = std::filesystem::path(file).parent_path() / path;
      if (std::filesystem::exists(beside)) path = beside.string();
    }
    if (!std::filesystem::exists(path)) c.fail("envmap.file", e["file"], path + ": no such file");
    PfmImage img;
    try {
      img = read_pfm(path);
    } catch (const Error& err) {
      c.fail("envmap.file", e["file"], err.what());
    }
    l.env_width = img.width;
    l.env_height = img.height;
    l.env = std::move(img.luminance);
    l.env_scale = e["scale"] ? number(c, "envmap.scale", e["scale"], 0, 1e12) : 1.0;
  }
  return l;
}

}  // namespace bsdfmix
