// The YAML config of `bsdfmix fit|converge|run`: one struct and one parser per section.
// Defaults live in configs/defaults.yaml (embedded), merged under the user's config;
// keys not in the defaults are rejected with their full path.
#pragma once

#include <yaml-cpp/yaml.h>

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "config/node.hpp"
#include "sweep/fit_settings.hpp"

namespace bsdfmix {

struct GenerateSection {  // tabulate the fiber model into `table`
  std::string model, preset;
  int theta_o = 0, theta_i = 0, phi_i = 0, phi_o = 1;
  bool symmetry = true;
  double noise = 0;
  std::uint64_t seed = 1;
  bool force = false;
};

struct ImportSection {  // tabulate an RGL BRDF into `table`
  std::string rgl;
  int theta_o = 0, theta_i = 0, phi_i = 0;
  bool force = false;
  std::string negative = "keep";  // keep or clip (tables/rgl_import.hpp RglNegative)
  bool resolve = false;           // raise the grid to resolve the narrowest lobe (tables/rgl_lobe.hpp)
};

// The `fit` section is the sweep's settings value (sweep/fit_settings.hpp).
using FitSection = FitSettings;

struct ConvergeSection {
  std::vector<double> theta_o, phi_o;
  std::int64_t samples_max = 65536;
  int runs = 64;
  std::uint64_t seed = 1;
  std::string csv;
  // every scene of `scene` (a file, an inline mapping, or a list of them); none: constant L_i = 1
  std::vector<YAML::Node> scenes;
  std::vector<std::string> scene_files;  // "" for an inline scene
  std::string mixture;                   // "" = fit.output
  std::vector<std::string> estimators;
  double uniform_fraction = 0.1;
  bool earned_share = true;  // uniform_fraction: earned (each slice's share from the mixture file)
  std::string tail_csv;  // "" = beside csv: <csv stem>_tail.csv
  bool cpu = false;      // the CPU reference instead of the device kernels
  // Sampling with the lighting (docs/sampling.md): MIS fractions and heuristic, the
  // product's pruning, where the lighting mixtures are cached, the lighting tail CSV.
  double light_fraction = 0.5, product_fraction = 0.8, product_light = 0.1;
  bool product_auto = true;  // product_fraction: auto (converge/quadrature.hpp, tune_product_fractions)
  int product_components = 128;
  bool power_heuristic = false;
  std::string light_mixture_dir;  // "" = <csv dir>/light_mixtures
  std::string light_tail_csv;     // "" = beside csv: <csv stem>_light_tail.csv
  // is_rgl, mis_light_rgl: the RGL file (.bsdf) whose warps they sample with; "" = import.rgl
  // when the config's import section made the table
  std::string rgl;
};

// The `render` section, parsed by the renderer (host/render/render_settings.hpp): the
// user's mapping with the defaults merged under its top-level keys, and the defaults
// themselves (for the nested mappings).
struct RenderSection {
  std::string file;
  YAML::Node node, defaults;
};

struct ChartsSection {
  std::string dir;
};

struct Config {
  std::string file;    // the config's path
  std::string device;  // device selector ("" = environment or 0)
  std::string table;
  std::optional<GenerateSection> generate;
  std::optional<ImportSection> import;
  std::optional<FitSection> fit;
  std::optional<ConvergeSection> converge;
  std::optional<ChartsSection> charts;
  std::optional<RenderSection> render;
};

// Reads, merges with the defaults and validates a config file; throws ConfigError.
Config load_config(const std::string& path);
// The same from YAML text (`name` stands for the file in messages).
Config parse_config(const std::string& text, const std::string& name);

// The device selector in force: the command line's when given, else the config's
// `device:` ("" leaves the choice to BSDFMIX_DEVICE, then device 0).
std::string device_for(const Config& config, const std::string& cli_selector);

// The defaults document (configs/defaults.yaml as embedded at build time).
const std::string& default_config_text();

// One parser per section; each takes the merged section node.
GenerateSection parse_generate(const ConfigNode& n);
ImportSection parse_import(const ConfigNode& n);
FitSection parse_fit(const ConfigNode& n);
ConvergeSection parse_converge(const ConfigNode& n);
ChartsSection parse_charts(const ConfigNode& n);

}  // namespace bsdfmix
