// mis_light_gmm: light sampling, the mixture and uniform by one-sample MIS (kernels/sample.cl
// ESTIMATOR 8); in the renderer the mixture's draw (with its uniform share) with light
// samples by MIS.
#include "sampling/draws.hpp"
#include "sampling/estimator_builtins.hpp"

namespace bsdfmix {
namespace {

using namespace draws;

// light, mixture, uniform
MisTechniques techniques(const Problem& p) {
  const MisOptions& m = p.mis;
  return {3,
          {m.light_fraction, (1 - m.light_fraction) * (1 - m.uniform_fraction), (1 - m.light_fraction) * m.uniform_fraction},
          {&kLightTechnique, &kMixtureTechnique, &kUniformTechnique}};
}

}  // namespace

EstimatorInfo builtin::mis_light_gmm() {
  EstimatorInfo e = study_entry(Estimator::MisLightGmm, "mis_light_gmm", "light + mixture + uniform", kNeedsLighting,
                                {draws::mis_estimate_of<techniques>, draws::mis_pdf_of<techniques>, nullptr}, true);
  e.render = path_part(BsdfSampler::Mixture, true);
  return e;
}

}  // namespace bsdfmix
