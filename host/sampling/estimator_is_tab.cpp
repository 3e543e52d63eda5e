// is_tab: the mixture's own sampler, the table's f (kernels/sample.cl ESTIMATOR 2).
#include "sampling/draws.hpp"
#include "sampling/estimator_builtins.hpp"

namespace bsdfmix {

EstimatorInfo builtin::is_tab() {
  const auto estimate = [](const Problem& p, const double u[4]) { return draws::mixture_estimate(p, u, draws::table_f); };
  return builtin::study_entry(Estimator::IsTab, "is_tab", "mixture", 0,
                              {estimate, draws::mixture_density, draws::mixture_direction}, true);
}

}  // namespace bsdfmix
