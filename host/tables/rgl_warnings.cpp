// The import's warnings (tables/rgl_warnings.hpp).
#include "tables/rgl_warnings.hpp"

#include <algorithm>
#include <cmath>

#include "core/format.hpp"

namespace bsdfmix {

namespace {
constexpr double kToDegrees = 57.29577951308232;
std::string deg(double radians, const char* f = "%.2f") { return format_number(radians * kToDegrees, f); }
}  // namespace

double rgl_peak_f(const std::vector<RglLobe>& lobes) {
  double peak = 0;
  for (const RglLobe& l : lobes)
    if (l.peak > 0) peak = std::max(peak, l.peak / std::max(std::cos(l.theta_i), 1e-6));
  return peak;
}

std::string rgl_table_bytes(double cells) {
  const double mib = cells * 16 / 1048576.0;
  return mib >= 1024 ? format_number(mib / 1024, "%.1f") + " GiB" : format_number(mib, "%.1f") + " MiB";
}

std::string rgl_coarse_grid_warning(const std::string& name, const std::vector<RglLobe>& lobes, double grid_max_f,
                                    std::size_t n_theta_o, std::size_t n_theta_i, std::size_t n_phi_i, bool resolved) {
  const double peak = rgl_peak_f(lobes);
  if (!(peak > 0) || grid_max_f >= kGridPeakShare * peak) return "";
  const RglGrid g = rgl_resolving_grid(lobes, n_theta_o, n_theta_i, n_phi_i);
  std::string text = name + ": the grid's largest f is " + format_number(grid_max_f, "%.3g") + " against the file's peak " +
                     format_number(peak, "%.3g") + ": its cells are coarser than the narrowest lobe (" +
                     deg(g.narrowest.fwhm_theta) + " x " + deg(g.narrowest.fwhm_phi) + " degrees at theta_o " +
                     deg(g.narrowest.theta_o, "%.1f") + ") and a fit will miss it; ";
  const bool same = g.n_theta_o == n_theta_o && g.n_theta_i == n_theta_i && g.n_phi_i == n_phi_i;
  if (resolved)
    return text + "the grid is at its caps: sample the file with its own warps (docs/rgl.md, \"Resolving sharp lobes\")";
  if (same) return text + "import with finer cells (--theta-o, --theta-i, --phi-i)";
  const double cells = double(g.n_theta_o) * double(g.n_theta_i) * double(g.n_phi_i);
  return text + "import with --resolve (" + std::to_string(g.n_theta_o) + " x " + std::to_string(g.n_theta_i) + " x " +
         std::to_string(g.n_phi_i) + " = " + format_number(cells, "%.3g") + " cells, " + rgl_table_bytes(cells) +
         " of table)" + (g.n_theta_i >= 720 || g.n_phi_i >= 1440 ? ", at its caps, or sample the file with its own warps" : "");
}

std::string rgl_negative_warning(const std::string& name, std::size_t negative, std::size_t cells, bool clipped) {
  if (negative == 0 || clipped) return "";
  return name + ": " + format_number(100.0 * double(negative) / double(std::max<std::size_t>(cells, 1)), "%.1f") +
         "% of cells hold a negative R, G or B (colours out of the sRGB gamut), kept signed: Mitsuba and pbrt clip "
         "them to 0 when they render the file, which raises its luminance there; import with --negative clip to "
         "match those renderers, keep (the default) to keep the measured colour (docs/rgl.md)";
}

}  // namespace bsdfmix
