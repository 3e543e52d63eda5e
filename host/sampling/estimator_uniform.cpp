// uniform: the renderer's uniform sampling over the material's domain (no light samples).
#include "sampling/estimator_builtins.hpp"

namespace bsdfmix {

EstimatorInfo builtin::uniform() {
  return builtin::render_entry(Estimator::Uniform, "uniform", "uniform", 0, builtin::path_part(BsdfSampler::Uniform, false));
}

}  // namespace bsdfmix
