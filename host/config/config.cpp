// Loading a config: parse, reject unknown keys, merge the defaults under it, parse each section.
#include "config/config.hpp"

#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "core/file_errors.hpp"

namespace bsdfmix {

namespace embedded {
const std::string& config_defaults();
}

const std::string& default_config_text() { return embedded::config_defaults(); }

namespace {

YAML::Node parse_yaml(const std::string& text, const std::string& name) {
  try {
    return YAML::Load(text);
  } catch (const YAML::Exception& e) {
    std::string msg = e.msg;
    throw ConfigError(name + ": invalid YAML at line " + std::to_string(e.mark.line + 1) + ", column " +
                      std::to_string(e.mark.column + 1) + ": " + msg);
  }
}

std::set<std::string> keys_of(const YAML::Node& map) {
  std::set<std::string> k;
  for (const auto& kv : map) k.insert(kv.first.Scalar());
  return k;
}

// The user's section with every missing key taken from the defaults.
YAML::Node merged(const YAML::Node& defaults, const YAML::Node& user) {
  YAML::Node out = YAML::Clone(defaults);
  if (user && user.IsMap())
    for (const auto& kv : user) out[kv.first.Scalar()] = kv.second;
  return out;
}

constexpr const char* kSections[] = {"generate", "import", "fit", "converge", "charts", "render"};

}  // namespace

Config parse_config(const std::string& text, const std::string& name) {
  const YAML::Node defaults = parse_yaml(default_config_text(), "configs/defaults.yaml");
  const YAML::Node user = parse_yaml(text, name);
  if (!user || user.IsNull()) throw ConfigError(name + ": the config is empty");
  ConfigNode top(name, "", user);
  top.reject_unknown(keys_of(defaults));

  Config c;
  c.file = name;
  // Every section the user names is checked for unknown keys against its defaults.
  for (const char* s : kSections) {
    if (!user[s]) continue;
    if (user[s].IsNull()) {
      continue;  // `fit:` alone: the section with all defaults
    }
    ConfigNode section = top.child(s);
    section.reject_unknown(keys_of(defaults[s]));
  }
  // Top-level keys are read from the user's own nodes (a clone would lose their line
  // numbers, and errors would name line 1); a missing device takes the default.
  ConfigNode root(name, "", user);
  c.device = root.has("device") ? root.str("device") : defaults["device"].Scalar();
  if (!root.has("table")) root.fail("table", "missing: name the table file (HDF5)");
  c.table = root.str("table");

  auto section = [&](const char* s) { return ConfigNode(name, s, merged(defaults[s], user[s])); };
  if (user["generate"]) c.generate = parse_generate(section("generate"));
  if (user["import"]) c.import = parse_import(section("import"));
  if (user["fit"]) c.fit = parse_fit(section("fit"));
  if (user["converge"]) c.converge = parse_converge(section("converge"));
  if (user["charts"]) c.charts = parse_charts(section("charts"));
  if (user["render"]) c.render = RenderSection{name, merged(defaults["render"], user["render"]), defaults["render"]};
  if (c.generate && c.import)
    throw ConfigError(name + ": generate and import both make the table; keep one");
  // is_rgl and mis_light_rgl sample with the RGL file the table came from
  if (c.converge && c.converge->rgl.empty() && !(c.import && !c.import->rgl.empty()))
    for (const std::string& e : c.converge->estimators)
      if (e == "is_rgl" || e == "mis_light_rgl")
        ConfigNode(name, "converge", user["converge"])
            .fail("rgl", e + " samples with an RGL file's own warps: name the .bsdf file the table was imported "
                             "from here (or import the table in this config, import.rgl)");
  if (!c.generate && !c.import && !exists_quiet(c.table))
    root.fail("table", c.table + ": no such file (and no generate or import section makes it)");
  return c;
}

std::string device_for(const Config& config, const std::string& cli_selector) {
  return cli_selector.empty() ? config.device : cli_selector;
}

Config load_config(const std::string& path) {
  const std::optional<std::string> text = read_text(path);
  if (!text) {
    const std::string why = unreadable_file(path);  // the one wording: "PATH: no such file"
    throw ConfigError(why.empty() ? path + ": cannot read the config" : why);
  }
  return parse_config(*text, path);
}

}  // namespace bsdfmix
