// uniform: the renderer's uniform sampling over the material's domain (no light samples).
#include "sampling/estimator_builtins.hpp"

namespace bsdfmix {

EstimatorInfo builtin::uniform() {
  EstimatorInfo e;
  e.id = Estimator::Uniform;
  e.name = "uniform";
  e.draws = "uniform";
  e.render = builtin::path_part(BsdfSampler::Uniform, false);
  return e;
}

}  // namespace bsdfmix
