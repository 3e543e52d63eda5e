// guided_product: the renderer's guided paths (docs/render.md, "Guided paths"): the guide's mixture and its product with the BSDF mixture draw shares of the directions, the
// BSDF mixture the rest, with light samples by MIS; without a guide, as mis_light_gmm.
#include "sampling/estimator_builtins.hpp"

namespace bsdfmix {

EstimatorInfo builtin::guided_product() {
  EstimatorInfo e;
  e.name = "guided_product";
  e.draws = "guide + guide x mixture + mixture + uniform, light";
  e.needs = kNeedsLighting | kNeedsGuide;
  e.render.renders = true;
  e.render.technique = BsdfSampler::Mixture;
  e.render.light_sampling = true;
  e.render.guided = true;
  e.render.guided_product = true;
  e.id = Estimator::GuidedProduct;
  return e;
}

}  // namespace bsdfmix
