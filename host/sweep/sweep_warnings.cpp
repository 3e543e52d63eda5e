// The fit's warnings (sweep/sweep_warnings.hpp).
#include "sweep/sweep_warnings.hpp"

#include "core/format.hpp"
#include "core/stats.hpp"

namespace bsdfmix {

// Its medians are core/stats' quantile, as in every summary.
std::string k_cap_warning(const std::vector<std::int32_t>& k, const std::vector<double>& l1_rel, int k_min, int k_max) {
  if (k_min >= k_max || k.empty()) return "";
  std::vector<double> capped, others;
  for (std::size_t s = 0; s < k.size(); ++s) (k[s] >= k_max ? capped : others).push_back(s < l1_rel.size() ? l1_rel[s] : 0);
  if (double(capped.size()) < kKCapShare * double(k.size())) return "";
  std::string text = "K reached k_max " + std::to_string(k_max) + " on " + std::to_string(capped.size()) + " of " +
                     std::to_string(k.size()) + " slices: raise fit.k_max (relative L1 median " +
                     percent_text(quantile(capped, 0.5)) + " on those slices";
  if (!others.empty()) text += ", " + percent_text(quantile(others, 0.5)) + " on the others";
  return text + ")";
}

std::string negative_channel_warning(const TableReader& table, const std::vector<SliceRef>& plan) {
  const TableMeta& meta = table.meta();
  if (!meta.rgb || plan.empty()) return "";
  std::size_t negative = 0, cells = 0;
  std::string which = "the fitted cells";
  if (meta.negative_rgb_cells >= 0) {  // counted when the table was written: nothing to read again
    negative = std::size_t(meta.negative_rgb_cells);
    cells = meta.n_slices() * meta.cells_per_slice();
    which = "the table's cells";
  } else {
    for (const SliceRef& r : plan) {
      const std::vector<float> rgb = table.read_slice_rgb(r.t_o, r.p_o);
      negative += count_negative_rgb(rgb.data(), rgb.size() / 3);
      cells += rgb.size() / 3;
    }
  }
  if (!negative) return "";
  return table.path() + ": " + format_number(100.0 * double(negative) / double(cells), "%.1f") + "% of " + which +
         " hold a negative R, G or B (kept signed), and the mixture's colour fits them: Mitsuba and "
         "pbrt clip them to 0 when they render the measured file; import it with --negative clip to match those "
         "renderers (docs/rgl.md)";
}

}  // namespace bsdfmix
