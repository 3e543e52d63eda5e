// The charts stage: runs the plotting scripts on what the other stages wrote.
#include "core/progress.hpp"
#include "pipeline/stages.hpp"

namespace bsdfmix {

void stage_charts(const Config& config) {
  log_line("charts: nothing to chart yet for " + config.file);
}

}  // namespace bsdfmix
