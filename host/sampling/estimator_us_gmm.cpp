// us_gmm: uniform sampling over the domain, the stand-in's f (kernels/sample.cl ESTIMATOR 1).
#include "sampling/draws.hpp"
#include "sampling/estimator_builtins.hpp"

namespace bsdfmix {

EstimatorInfo builtin::us_gmm() {
  const auto estimate = [](const Problem& p, const double u[4]) { return draws::uniform_estimate(p, u, draws::stand_in_f); };
  return builtin::study_entry(Estimator::UsGmm, "us_gmm", "uniform", kStandInF,
                              {estimate, draws::uniform_density, draws::uniform_direction}, true);
}

}  // namespace bsdfmix
