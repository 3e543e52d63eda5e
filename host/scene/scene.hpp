// Convergence scenes (docs/sampling.md, "Scenes"): YAML into Lighting, and the PFM
// reader of environment maps.
#pragma once

#include <yaml-cpp/yaml.h>

#include <string>
#include <vector>

#include "sampling/lighting.hpp"

namespace bsdfmix {

// A scene mapping (from `file`, or inline in a config when file names the config and
// `where` the key). Errors are ConfigError naming file, key and problem.
Lighting parse_scene(const YAML::Node& node, const std::string& file, const std::string& where, Domain domain);

// A PFM image ("PF" RGB or "Pf" gray, any endianness) as luminance, row 0 at the top.
struct PfmImage {
  int width = 0, height = 0;
  std::vector<float> luminance;
};
PfmImage read_pfm(const std::string& path);
// Writes a gray ("Pf") little-endian PFM, row 0 at the top.
void write_pfm(const std::string& path, const PfmImage& image);

}  // namespace bsdfmix
