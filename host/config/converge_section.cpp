// The `converge` section: the Monte Carlo convergence study.
#include "config/config.hpp"

#include <cmath>
#include <filesystem>

#include "core/domain.hpp"

namespace bsdfmix {

ConvergeSection parse_converge(const ConfigNode& n) {
  ConvergeSection c;
  if (n.has("scene")) {
    const YAML::Node s = n.raw("scene");
    if (s.IsScalar()) {
      c.scene_file = s.Scalar();
      if (!std::filesystem::exists(c.scene_file)) n.fail("scene", "file '" + c.scene_file + "' not found");
      try {
        c.scene = YAML::LoadFile(c.scene_file);
      } catch (const YAML::Exception& e) {
        n.fail("scene", "'" + c.scene_file + "' is not valid YAML (line " + std::to_string(e.mark.line + 1) +
                            "): " + e.msg);
      }
    } else if (s.IsMap()) {
      c.scene = s;
    } else {
      n.fail("scene", "expected a scene file name or an inline scene mapping");
    }
  }
  c.theta_o = n.numbers("theta_o");
  c.phi_o = n.numbers("phi_o");
  for (double t : c.theta_o)
    if (t < -kPi / 2 || t > kPi / 2) n.fail("theta_o", "angle " + std::to_string(t) + " rad is outside [-pi/2, pi/2]");
  c.samples_max = n.integer("samples_max", 1, std::int64_t(1) << 32);
  c.runs = static_cast<int>(n.integer("runs", 2, 1000000));
  c.seed = static_cast<std::uint64_t>(n.integer("seed", 0, INT64_MAX));
  c.csv = n.str("csv");
  return c;
}

ChartsSection parse_charts(const ConfigNode& n) {
  ChartsSection c;
  c.dir = n.str("dir");
  return c;
}

}  // namespace bsdfmix
