// Fit time and fit error against K for chosen slices: the data of the speed-against-
// accuracy chart. Each (slice, K) is fitted alone by the sweep with K pinned (the search's
// final fits at that K: split-and-merge, the final settings, the L1 refinement) and timed.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "fit/em.hpp"
#include "sweep/fit_settings.hpp"

namespace bsdfmix {

struct KTimingRow {
  std::size_t slice = 0;
  std::string type;  // what the slice stands for ("sharp", "medium", "broad")
  double theta_o = 0;
  int k = 0;
  double seconds = 0, l1_rel = 0;
  int iterations = 0;
};

// Times every candidate K of fit.k_min..fit.k_max on each listed slice (table slice
// indices, with their type labels).
std::vector<KTimingRow> time_k(const std::string& table_path, const FitSettings& fit, const std::string& device_selector,
                               const std::vector<std::size_t>& slices, const std::vector<std::string>& types,
                               const EngineOptions& engine = {});

// Writes the rows as CSV `slice,type,theta_o,k,seconds,iterations,l1_rel` (atomically).
void write_k_timing_csv(const std::string& path, const std::vector<KTimingRow>& rows);

}  // namespace bsdfmix
