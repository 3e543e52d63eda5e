// The convergence stage: the Monte Carlo study of the estimators.
#include "core/error.hpp"
#include "pipeline/stages.hpp"

namespace bsdfmix {

void stage_converge(const Config& config, const std::string&) {
  throw UnavailableError(config.file + ": converge: the convergence study is not yet available in this build");
}

}  // namespace bsdfmix
