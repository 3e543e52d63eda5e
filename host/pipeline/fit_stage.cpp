// The fit stage: Gaussian-count search and final fits over the table's slices.
#include "core/error.hpp"
#include "pipeline/stages.hpp"

namespace bsdfmix {

void stage_fit(const Config& config, const std::string&) {
  throw UnavailableError(config.file + ": fit: the fitting sweep is not yet available in this build");
}

}  // namespace bsdfmix
