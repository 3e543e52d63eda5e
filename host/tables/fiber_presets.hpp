// Named parameter sets of the fiber model (docs/fiber.md, "Presets").
#pragma once

#include <string>
#include <vector>

#include "tables/fiber_model.hpp"

namespace bsdfmix {

struct FiberPreset {
  std::string name;
  FiberParams params;     // alpha in radians; sigma_a per channel (R, G, B)
  FiberRgb color{};       // the colour of a mass of these fibers that sigma_a gives (linear
                          // Rec. 709 RGB, Chiang et al. 2016's mapping, sigma_a_from_color);
                          // 1, 1, 1 for lossless
  std::string rationale;  // one line: why these values
};

// silk, cotton, polyester, wool, lossless (in that order).
const std::vector<FiberPreset>& fiber_presets();

// "silk, cotton, polyester, wool, lossless".
std::string fiber_preset_names();

// The preset called `name`; throws ConfigError listing the presets when there is none.
const FiberPreset& fiber_preset(const std::string& name);

}  // namespace bsdfmix
