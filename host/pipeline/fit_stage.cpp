// The fit stage: Gaussian-count search and final fits over the table's slices.
#include <cstdio>

#include "core/progress.hpp"
#include "pipeline/stages.hpp"
#include "sweep/sweep.hpp"

namespace bsdfmix {

void stage_fit(const Config& config, const std::string& device_selector, const SweepOptions& options) {
  const SweepSummary s = run_sweep(config.table, *config.fit, device_selector, options);
  if (!s.complete) return;
  std::printf("fit %s -> %s, %s, %s\n%s", config.table.c_str(), config.fit->output.c_str(), config.fit->report.c_str(),
              config.fit->search_report.c_str(), s.text().c_str());
  std::fflush(stdout);
  for (const std::string& w : s.warnings) warn_line(w);
}

}  // namespace bsdfmix
