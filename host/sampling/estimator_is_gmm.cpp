// is_gmm: the mixture's own sampler, the stand-in's f (kernels/sample.cl ESTIMATOR 3).
#include "sampling/draws.hpp"
#include "sampling/estimator_builtins.hpp"

namespace bsdfmix {

EstimatorInfo builtin::is_gmm() {
  const auto estimate = [](const Problem& p, const double u[4]) { return draws::mixture_estimate(p, u, draws::stand_in_f); };
  return builtin::study_entry(Estimator::IsGmm, "is_gmm", "mixture", kStandInF,
                              {estimate, draws::mixture_density, draws::mixture_direction}, true);
}

}  // namespace bsdfmix
