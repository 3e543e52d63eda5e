// `bsdfmix render CONFIG.yaml` (docs/render.md): the table, a pre-pass for the theta_o the
// scene needs, the fit of only those slices, the converged reference, every estimator at
// equal samples and at equal time, the stand-in against the table, render.csv,
// render.json and the figures.
#pragma once

#include <string>

#include "config/config.hpp"

namespace bsdfmix {
namespace render {

void run_render(const Config& config, const std::string& device_selector, bool figures = true);

}  // namespace render
}  // namespace bsdfmix
