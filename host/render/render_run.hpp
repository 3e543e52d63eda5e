// `bsdfmix render CONFIG.yaml` (docs/render.md), as stages over the layers below: the
// slices the camera needs (a pre-pass), the mixtures of only those slices, the converged
// reference, every estimator at equal samples and at equal time with the stand-in against
// the table, then render.csv and render.json.
#pragma once

#include <string>

#include "fit/em.hpp"
#include "render/guide_training.hpp"
#include "render/render_settings.hpp"
#include "sweep/fit_settings.hpp"

namespace bsdfmix {
namespace render {

// Whether some estimator of the render samples with the RGL file's warps.
bool needs_rgl(const RenderSettings& s);

// What a render reads besides its own settings: the table, the RGL file the table was
// imported from ("" when it was not; the estimators of needs_rgl sample with it), the
// settings the mixtures it needs are fitted with, the devices that fit them and how their
// engines run.
struct RenderInputs {
  std::string table;
  std::string rgl;
  FitSettings fit;
  std::string device_selector;
  EngineOptions engine;
};

// What the guided estimators learn with: the settings' guide, its leaves fitted with
// `fit`'s seed, penalty and search (up to the guide's k_max, one restart, no refinement),
// on the devices of `device_selector` when some estimator is guided, the engine run as
// `engine` says.
GuideSetup guide_setup(const RenderSettings& s, const FitSettings& fit, const std::string& device_selector,
                       const EngineOptions& engine = {});

// Renders the scene of `s` into s.output (images, render.csv, render.json); the table of
// `in` must exist (the CLI makes it first) and is read once. The figures are the command's
// (scripts/render_figures.py over s.output).
void run_render(const RenderSettings& s, const RenderInputs& in);

}  // namespace render
}  // namespace bsdfmix
