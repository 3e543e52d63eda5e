// The fiber presets. Parameters follow the ranges of Chiang et al. 2016 and of the
// textile literature; each absorption is sigma_a_from_color (Chiang et al. 2016, section
// 4.2) of the preset's colour at its beta_n, to 4 significant digits (tests/fiber_test.cpp
// checks it). docs/fiber.md has the table; docs/studies/fiber_colour.md where each colour comes from.
#include "tables/fiber_presets.hpp"

#include "core/domain.hpp"
#include "core/error.hpp"

namespace bsdfmix {

namespace {
constexpr double kDeg = kPi / 180.0;

FiberPreset make(const char* name, double eta, FiberRgb sigma_a, FiberRgb color, double beta_m, double beta_n,
                 double alpha_deg, const char* why) {
  FiberPreset p;
  p.name = name;
  p.params.eta = eta;
  p.params.sigma_a = sigma_a;
  p.params.beta_m = beta_m;
  p.params.beta_n = beta_n;
  p.params.alpha = alpha_deg * kDeg;
  p.color = color;
  p.rationale = why;
  return p;
}
}  // namespace

const std::vector<FiberPreset>& fiber_presets() {
  // Colours, linear Rec. 709 RGB (docs/fiber.md, "Colour"):
  //   silk       ivory of natural (undyed) Bombyx mori silk, chosen by eye;
  //   cotton     undyed cotton, Rd 75 % and +b 9.0 (the ITC Cotton Guide's typical values);
  //   polyester  the ColorChecker's "Red" patch, sRGB AF363C: a red disperse-dyed PET;
  //   wool       scoured wool, IWTO clean colour Y 60, Y - Z 6 (chosen within the published range);
  //   lossless   white: no absorption.
  static const std::vector<FiberPreset> presets = {
      make("silk", 1.55, {0.0007617, 0.001436, 0.004290}, {0.85, 0.80, 0.68}, 0.15, 0.30, 1.0,
           "smooth translucent protein filament: narrow longitudinal lobes, strong TT and TRT, small tilt; ivory"),
      make("cotton", 1.53, {0.002391, 0.004715, 0.01237}, {0.8109, 0.7450, 0.6207}, 0.60, 0.80, 3.0,
           "twisted rough cellulose fiber: broad longitudinal and azimuthal lobes, matte; undyed cream"),
      make("polyester", 1.64, {0.02019, 0.3065, 0.2699}, {0.4287, 0.0369, 0.0452}, 0.08, 0.15, 0.0,
           "smooth synthetic (PET) filament: sharpest lobes, no scales; dyed red (absorbs green and blue)"),
      make("wool", 1.55, {0.005730, 0.008435, 0.01613}, {0.6525, 0.5957, 0.4885}, 0.30, 0.45, 4.0,
           "keratin fiber with cuticle scales like hair: medium roughness, the largest tilt; scoured cream"),
      make("lossless", 1.55, {0.0, 0.0, 0.0}, {1.0, 1.0, 1.0}, 0.30, 0.30, 2.0,
           "no absorption in any channel: f integrates to 1 over the sphere (white-furnace tests)"),
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
