// Tabulates a measured RGL BRDF on the hemisphere grid (docs/formats.md, "Grids"),
// with azimuthal symmetry.
#pragma once

#include <cstddef>
#include <string>

namespace bsdfmix {

// Negative RGB channels: measured colours out of the sRGB gamut (docs/rgl.md). `Keep` stores
// them signed, with the luminance of the signed values; `Clip` sets each channel to
// max(0, c) before the luminance, as the RGL authors' reference code, Mitsuba 3 and
// pbrt-v4 do when they render the file.
enum class RglNegative { Keep, Clip };
const char* rgl_negative_name(RglNegative n);             // keep, clip
bool parse_rgl_negative(const std::string& name, RglNegative& out);  // false: not a name

struct RglImportOptions {
  std::string file;  // the .bsdf file
  std::size_t n_theta_o = 90, n_theta_i = 90, n_phi_i = 180;
  unsigned threads = 0;  // 0: std::thread::hardware_concurrency()
  RglNegative negative = RglNegative::Keep;
  // Raise the three resolutions (never lower them) until the file's narrowest lobe is
  // resolved (tables/rgl_lobe.hpp, rgl_resolving_grid).
  bool resolve = false;
};

// Writes the table (atomically) to out_path: `values` the luminance of f, `rgb` beside
// it, one slice per theta_o at phi_o = 0, cells at the grid's centers. Cells below the
// horizon cannot occur (centers lie inside the hemisphere). Throws InputError on a bad
// file or options, IoError on a write failure.
void import_rgl_table(const RglImportOptions& opt, const std::string& out_path);

}  // namespace bsdfmix
