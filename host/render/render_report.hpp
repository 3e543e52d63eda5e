// What a render reports (docs/render.md, "Outputs"): render.csv, one
// row per image and per progress point, and render.json, the scene, the sizes of the
// table and of the mixtures, and the stand-in's differences; both written atomically.
#pragma once

#include <cstdint>
#include <string>

#include "render/comparisons.hpp"

namespace bsdfmix {
namespace render {

struct RenderFacts {
  std::string scene, fiber;            // the lighting's name, the table's file stem
  std::uint64_t table_bytes = 0;       // the table's cells (float32)
  std::uint64_t full_table_bytes = 0;  // the same without azimuthal symmetry
  std::uint64_t mixture_bytes = 0;     // the mixtures' datasets
  std::size_t slices_needed = 0, slices_total = 0;
  std::size_t fibers = 0, segments = 0;
};

// Writes `csv` (the reference row first, then the comparisons' rows) and `json`.
void write_render_report(const std::string& csv, const std::string& json, const RenderSettings& s,
                         const RenderFacts& facts, const Comparisons& c);

}  // namespace render
}  // namespace bsdfmix
