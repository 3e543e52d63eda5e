// uniform: the renderer's uniform sampling over the material's domain (no light samples).
#include "sampling/estimator_builtins.hpp"

namespace bsdfmix {

EstimatorInfo builtin::uniform() {
  EstimatorInfo e;
  e.name = "uniform";
  e.draws = "uniform";
  e.render.renders = true;
  e.render.technique = BsdfSampler::Uniform;
  e.id = Estimator::Uniform;
  return e;
}

}  // namespace bsdfmix
