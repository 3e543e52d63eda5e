// guided: the renderer's guided paths (docs/render.md, "Guided paths"): the guide's mixture of the vertex's leaf draws a share of the directions, the
// BSDF mixture the rest, with light samples by MIS; without a guide, as mis_light_gmm.
#include "sampling/estimator_builtins.hpp"

namespace bsdfmix {

EstimatorInfo builtin::guided() {
  EstimatorInfo e;
  e.id = Estimator::Guided;
  e.name = "guided";
  e.draws = "guide + mixture + uniform, light";
  e.needs = kNeedsLighting | kNeedsGuide;
  e.render = builtin::path_part(BsdfSampler::Mixture, true);
  e.render.guided = true;
  return e;
}

}  // namespace bsdfmix
