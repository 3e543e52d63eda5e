// us_tab: uniform sampling over the domain, the table's f (kernels/sample.cl ESTIMATOR 0).
#include "sampling/draws.hpp"
#include "sampling/estimator_builtins.hpp"

namespace bsdfmix {

EstimatorInfo builtin::us_tab() {
  const auto estimate = [](const Problem& p, const double u[4]) { return draws::uniform_estimate(p, u, draws::table_f); };
  return builtin::study_entry(Estimator::UsTab, "us_tab", "uniform", 0,
                              {estimate, draws::uniform_density, draws::uniform_direction}, true);
}

}  // namespace bsdfmix
