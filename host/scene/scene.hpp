// Scenes (docs/sampling.md, "Scenes"), of the convergence study and of the renderer:
// YAML into Lighting; environment maps are read by host/io/pfm.hpp.
#pragma once

#include <yaml-cpp/yaml.h>

#include <string>

#include "sampling/lighting.hpp"

namespace bsdfmix {

// A scene mapping (from `file`, or inline in a config when file names the config and
// `where` the key). Errors are ConfigError naming file, key and problem.
Lighting parse_scene(const YAML::Node& node, const std::string& file, const std::string& where, Domain domain);

}  // namespace bsdfmix
