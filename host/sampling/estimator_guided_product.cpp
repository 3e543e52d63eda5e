// guided_product: the renderer's guided paths (docs/render.md, "Guided paths"): the guide's mixture and its product with the BSDF mixture draw shares of the directions, the
// BSDF mixture the rest, with light samples by MIS; without a guide, as mis_light_gmm.
#include "sampling/estimator_builtins.hpp"

namespace bsdfmix {

EstimatorInfo builtin::guided_product() {
  EstimatorInfo e;
  e.id = Estimator::GuidedProduct;
  e.name = "guided_product";
  e.draws = "guide + guide x mixture + mixture + uniform, light";
  e.needs = kNeedsLighting | kNeedsGuide;
  e.render = builtin::path_part(BsdfSampler::Mixture, true);
  e.render.guided = true;
  e.render.guided_product = true;
  return e;
}

}  // namespace bsdfmix
