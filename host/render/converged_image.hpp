// The converged image of a render, the reference of its comparisons (docs/render.md,
// "Outputs"; reference.exr): the table as f,
// the reference estimator at reference_spp. Cached in the output directory under its key
// (everything its pixels depend on), and checkpointed every 1/16 of its passes, so that a
// killed render resumes to the same image an uninterrupted one makes.
#pragma once

#include <cstdint>
#include <string>

#include "render/integrator.hpp"

namespace bsdfmix {
namespace render {

// Everything a render's pixels depend on but the estimator and the sample count; the
// table by its path and the hash of its file's bytes (hash_file's value, as load_table
// gives it), and the running build (a hash of its executable).
std::string scene_key(const RenderSettings& s, const std::string& table, std::uint64_t table_hash);

// The converged image: read from <output>/reference.pfm when <output>/reference.key holds `key`,
// else rendered (resuming from <output>/reference.partial.h5 when it was made under the
// same key) and written as reference.exr, reference.pfm and reference.key.
Image converged_image(const SceneView& view, const RenderSettings& s, const std::string& key);

// Sums of `passes` passes over a width x height image ([height][width][3]) as an image
// (the mean per pixel and channel).
Image mean_image(const std::vector<double>& sum, int passes, int width, int height);

// Writes <dir>/<stem>.exr and <dir>/<stem>.pfm.
void save_image(const std::string& dir, const std::string& stem, const Image& image);

}  // namespace render
}  // namespace bsdfmix
