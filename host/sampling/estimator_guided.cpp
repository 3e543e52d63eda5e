// guided: the renderer's guided paths (docs/render.md, "Guided paths"): the mixture of the
// guide's leaf at the vertex draws a share of the directions, the BSDF mixture the rest,
// with light samples by MIS; without a guide, as mis_light_gmm.
#include "sampling/estimator_builtins.hpp"

namespace bsdfmix {

EstimatorInfo builtin::guided() {
  PathStrategy r = path_part(BsdfSampler::Mixture, true);
  r.guided = true;
  return render_entry(Estimator::Guided, "guided", "guide + mixture + uniform, light", kNeedsLighting | kNeedsGuide, r);
}

}  // namespace bsdfmix
