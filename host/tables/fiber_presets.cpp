// The fiber presets. Parameters follow the ranges of Chiang et al. 2016 and of the
// textile literature (docs/fiber.md has the table and the reasons).
#include "tables/fiber_presets.hpp"

#include "core/domain.hpp"
#include "core/error.hpp"

namespace bsdfmix {

namespace {
constexpr double kDeg = kPi / 180.0;

FiberPreset make(const char* name, double eta, double sigma_a, double beta_m, double beta_n, double alpha_deg,
                 const char* why) {
  FiberPreset p;
  p.name = name;
  p.params.eta = eta;
  p.params.sigma_a = sigma_a;
  p.params.beta_m = beta_m;
  p.params.beta_n = beta_n;
  p.params.alpha = alpha_deg * kDeg;
  p.rationale = why;
  return p;
}
}  // namespace

const std::vector<FiberPreset>& fiber_presets() {
  static const std::vector<FiberPreset> presets = {
      make("silk", 1.55, 0.10, 0.15, 0.30, 1.0,
           "smooth translucent protein filament: narrow longitudinal lobes, strong TT and TRT, small tilt"),
      make("cotton", 1.53, 0.60, 0.60, 0.80, 3.0,
           "twisted rough cellulose fiber: broad longitudinal and azimuthal lobes, absorbing, matte"),
      make("polyester", 1.64, 0.02, 0.08, 0.15, 0.0,
           "smooth clear synthetic (PET) filament: sharpest lobes, almost no absorption, no scales"),
      make("wool", 1.55, 0.30, 0.30, 0.45, 4.0,
           "keratin fiber with cuticle scales like hair: medium roughness, the largest tilt"),
      make("lossless", 1.55, 0.0, 0.30, 0.30, 2.0,
           "no absorption: f integrates to 1 over the sphere (white-furnace tests)"),
  };
  return presets;
}

std::string fiber_preset_names() {
  std::string s;
  for (const auto& p : fiber_presets()) s += (s.empty() ? "" : ", ") + p.name;
  return s;
}

const FiberPreset& fiber_preset(const std::string& name) {
  for (const auto& p : fiber_presets())
    if (p.name == name) return p;
  throw ConfigError("unknown fiber preset '" + name + "' (presets: " + fiber_preset_names() + ")");
}

}  // namespace bsdfmix
