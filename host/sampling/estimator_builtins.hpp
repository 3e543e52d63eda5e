// The built-in estimators, one file each (host/sampling/estimator_<name>.cpp), listed by
// the registry (host/sampling/estimator_registry.cpp).
#pragma once

#include "sampling/estimator.hpp"

namespace bsdfmix {
namespace builtin {

EstimatorInfo us_tab();
EstimatorInfo us_gmm();
EstimatorInfo is_tab();
EstimatorInfo is_gmm();
EstimatorInfo uniform();
EstimatorInfo mis_tab();
EstimatorInfo cdf_tab();
EstimatorInfo light();
EstimatorInfo mis_light_cdf();
EstimatorInfo mis_light_gmm();
EstimatorInfo product();
EstimatorInfo mis_product();
EstimatorInfo guided();
EstimatorInfo guided_product();
EstimatorInfo is_rgl();
EstimatorInfo mis_light_rgl();

}  // namespace builtin
}  // namespace bsdfmix
