// The `generate` and `import` sections: how the table is made when it is missing.
#include "config/config.hpp"

#include <filesystem>

namespace bsdfmix {

GenerateSection parse_generate(const ConfigNode& n) {
  GenerateSection g;
  g.model = n.str("model");
  if (g.model != "fiber") n.fail("model", "unknown model '" + g.model + "' (known: fiber)");
  g.preset = n.str("preset");
  g.theta_o = static_cast<int>(n.integer("theta_o", 1, 100000));
  g.theta_i = static_cast<int>(n.integer("theta_i", 2, 100000));
  g.phi_i = static_cast<int>(n.integer("phi_i", 2, 100000));
  g.phi_o = static_cast<int>(n.integer("phi_o", 1, 100000));
  g.symmetry = n.boolean("symmetry");
  if (g.symmetry && g.phi_o != 1) n.fail("phi_o", "must be 1 with symmetry: true");
  if (!g.symmetry && g.phi_o < 2) n.fail("phi_o", "must be 2 or more with symmetry: false (one column is symmetry)");
  g.noise = n.number("noise", 0.0, 10.0);
  g.seed = static_cast<std::uint64_t>(n.integer("seed", 0, INT64_MAX));
  g.force = n.boolean("force");
  return g;
}

ImportSection parse_import(const ConfigNode& n) {
  ImportSection s;
  if (!n.has("rgl")) n.fail("rgl", "missing: name the .bsdf file to import");
  s.rgl = n.str("rgl");
  if (!exists_quiet(s.rgl)) n.fail("rgl", s.rgl + ": no such file");
  s.theta_o = static_cast<int>(n.integer("theta_o", 1, 100000));
  s.theta_i = static_cast<int>(n.integer("theta_i", 2, 100000));
  s.phi_i = static_cast<int>(n.integer("phi_i", 2, 100000));
  s.force = n.boolean("force");
  s.resolve = n.boolean("resolve");
  s.negative = n.str("negative");
  if (s.negative != "keep" && s.negative != "clip")
    n.fail("negative", "'" + s.negative + "' is not a choice (expected keep or clip)");
  return s;
}

}  // namespace bsdfmix
