// The lighting as a Gaussian mixture (docs/sampling.md, "Sampling with the lighting"):
// L_i tabulated over the table's (theta_i, phi_i) grid in the scene's frame and fitted
// by the same sweep as the BSDF (weighted EM kernels, Gaussian-count search), with the
// weights L_i alone, no Jacobian: the product with the BSDF mixture (fitted to f c J)
// then follows f c L J, the integrand over (theta, phi). Fitted once per (scene, frame,
// grid, fit settings) and cached.
#pragma once

#include <bsdfmix/mixture.hpp>

#include <string>

#include "fit/em.hpp"
#include "io/table.hpp"
#include "sampling/lighting.hpp"
#include "sweep/fit_settings.hpp"

namespace bsdfmix {

struct LightMixture {
  // phi in the lighting's frame; scale = the integral of L over (theta, phi), over solid
  // angle on an equal-area map
  mix::SliceMixture mixture;
  std::string path;           // the cached mixture file
  int k = 0;
  double l1_rel = 0;          // the fit's relative L1 error over the grid
  double fit_seconds = 0;     // how long its fit took (when cached: as recorded beside it, else 0)
  bool cached = false;
};

// The lighting's cell weights: the integral of L over each cell of `grid` in (theta, phi)
// (midpoint sub-cell rule fine enough for the lighting's smallest feature), [theta][phi].
std::vector<double> lighting_cell_weights(const Lighting& light, const TableMeta& grid);

// Reads `<cache_dir>/light_<scene>_<hash>.h5` when it is there, else fits it with
// `fit` (its output paths replaced) on `device_selector`, the engine run as `engine` says,
// and writes it there.
LightMixture lighting_mixture(const Lighting& light, const TableMeta& grid, const FitSettings& fit,
                              const std::string& cache_dir, const std::string& device_selector,
                              const EngineOptions& engine = {});

}  // namespace bsdfmix
