// The comparisons of a render against its reference (docs/render.md, "Outputs"): every
// estimator at equal samples (with its error after 1, 2, 4, ... passes) and at equal time,
// and the mixture stand-in as f against the table with the same estimator, seed and samples.
#pragma once

#include <string>
#include <vector>

#include "render/guide_training.hpp"
#include "render/integrator.hpp"

namespace bsdfmix {
namespace render {

// One row of render.csv (docs/render.md, "Outputs").
struct RenderRow {
  std::string estimator, mode, image;
  int spp = 0;
  double seconds = 0, rays_per_second = 0, rel_mse = -1;  // rel_mse < 0: none
  double ns_per_vertex = 0;  // thread-nanoseconds per path vertex; 0: none
  // rel_mse over the pixels that show the material (render/integrator.hpp's material_mask)
  double rel_mse_material = -1;
};

struct Comparisons {
  std::vector<RenderRow> rows;
  double equal_time_seconds = 0;  // the budget of the equal-time renders
  // The stand-in image against the table image (stand_in set): mean relative RGB difference
  // per pixel and over 4 x 4 blocks, the table image's own noise against the reference
  // over 4 x 4 blocks, and the relative difference of the image means (luminance, and
  // each channel); -1 / 0 when not run.
  double stand_in_difference = -1, stand_in_difference_4x4 = -1, table_noise_4x4 = -1, stand_in_mean = 0;
  double stand_in_channel_mean[3] = {0, 0, 0};
};

// Renders every comparison the settings ask for, writing each image to the output
// directory (<estimator>_spp, <estimator>_time, table, stand_in; EXR and PFM). The guided
// estimators learn with `guide` in each of their renders (render/guide_training.hpp).
Comparisons run_comparisons(const SceneView& view, const RenderSettings& s, const Image& reference,
                            const GuideSetup& guide);

// sum |a - b| / sum |b| over blocks of `block` x `block` pixels and the three channels: the
// mean relative RGB difference of two images, with the Monte Carlo noise of both reduced by
// the blocks.
double image_difference(const Image& a, const Image& b, int block);

}  // namespace render
}  // namespace bsdfmix
