// `bsdfmix render CONFIG.yaml` (docs/render.md), as stages over the layers below: the
// slices the camera needs (a pre-pass), the mixtures of only those slices, the converged
// reference, every estimator at equal samples and at equal time with the stand-in against
// the table, then render.csv and render.json.
#pragma once

#include <string>

#include "config/config.hpp"
#include "render/guide_training.hpp"
#include "render/render_settings.hpp"

namespace bsdfmix {
namespace render {

// The render settings of a config, checked before any work: ConfigError when the config
// has no render or no fit section, or names a bad render setting, or an estimator that
// samples with an RGL file's warps (is_rgl, mis_light_rgl) where the table was not
// imported from one (import.rgl).
RenderSettings render_settings(const Config& config);

// Whether some estimator of the render samples with the RGL file's warps.
bool needs_rgl(const RenderSettings& s);

// What the guided estimators learn with: the settings' guide, its leaves fitted with
// `fit`'s seed, penalty and search (up to the guide's k_max, one restart, no refinement),
// on the devices of `device_selector` when some estimator is guided.
GuideSetup guide_setup(const RenderSettings& s, const FitSection& fit, const std::string& device_selector);

// Renders the config's scene into s.output (images, render.csv, render.json); its table
// must exist (the CLI makes it first) and is read once. The figures are the command's
// (scripts/render_figures.py over s.output).
void run_render(const Config& config, const RenderSettings& s, const std::string& device_selector);

}  // namespace render
}  // namespace bsdfmix
