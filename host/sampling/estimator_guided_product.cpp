// guided_product: guided, and the product of the leaf's compact part carried into the
// hit's frame with the BSDF mixture draws a share of the guide's directions (docs/render.md,
// "Guided paths").
#include "sampling/estimator_builtins.hpp"

namespace bsdfmix {

EstimatorInfo builtin::guided_product() {
  PathStrategy r = path_part(BsdfSampler::Mixture, true);
  r.guided = true;
  r.guided_product = true;
  return render_entry(Estimator::GuidedProduct, "guided_product", "guide + guide x mixture + mixture + uniform, light",
                      kNeedsLighting | kNeedsGuide, r);
}

}  // namespace bsdfmix
