// `bsdfmix render CONFIG.yaml` (docs/render.md), as stages over the layers below: the
// slices the camera needs (a pre-pass), the mixtures of only those slices, the converged
// reference, every estimator at equal samples and at equal time with the stand-in against
// the table, then render.csv, render.json and the figures.
#pragma once

#include <string>

#include "config/config.hpp"
#include "render/render_settings.hpp"

namespace bsdfmix {
namespace render {

// The render settings of a config, checked before any work: ConfigError when the config
// has no render or no fit section, or names a bad render setting.
RenderSettings render_settings(const Config& config);

// Renders the config's scene; its table must exist (the CLI makes it first).
void run_render(const Config& config, const RenderSettings& s, const std::string& device_selector,
                bool figures = true);

}  // namespace render
}  // namespace bsdfmix
