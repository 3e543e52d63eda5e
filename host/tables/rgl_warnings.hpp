// The import's warnings (docs/rgl.md): a grid that misses the file's peak, and cells
// that hold a negative channel. Each is one line of text, empty when there is nothing
// to say; the caller prints it with warn_line.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "tables/rgl_lobe.hpp"

namespace bsdfmix {

// A grid whose largest f is below this share of the file's peak f misses the peak.
constexpr double kGridPeakShare = 0.5;

// The file's largest f (luminance) at the lobes' peaks: peak / cos(theta_i) (0 without lobes).
double rgl_peak_f(const std::vector<RglLobe>& lobes);

// When grid_max_f (the largest f the table holds) is below kGridPeakShare of the file's
// peak: the two values, the narrowest lobe, and the grid `--resolve` would take with its
// cost (cells, bytes). `resolved`: the grid is already the resolving one (at its caps).
std::string rgl_coarse_grid_warning(const std::string& name, const std::vector<RglLobe>& lobes, double grid_max_f,
                                    std::size_t n_theta_o, std::size_t n_theta_i, std::size_t n_phi_i, bool resolved);

// When `negative` of `cells` cells hold a negative R, G or B and they were kept signed:
// their share and what `--negative keep` and `clip` mean for a renderer.
std::string rgl_negative_warning(const std::string& name, std::size_t negative, std::size_t cells, bool clipped);

// The table's bytes: 16 per cell (luminance and R, G, B in float32), in MiB or GiB.
std::string rgl_table_bytes(double cells);

}  // namespace bsdfmix
