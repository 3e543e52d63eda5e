// The built-in estimators, one file each (host/sampling/estimator_<name>.cpp), listed by
// the registry (host/sampling/estimator_registry.cpp).
#pragma once

#include "sampling/estimator.hpp"

namespace bsdfmix {
namespace builtin {

// An entry with its renderer part (none in the study).
inline EstimatorInfo render_entry(Estimator id, const char* name, const char* draws, unsigned needs,
                                  const PathStrategy& render) {
  EstimatorInfo e;
  e.id = id;
  e.name = name;
  e.draws = draws;
  e.needs = needs;
  e.render = render;
  return e;
}

// A study estimator's entry; `kernel`: kernels/sample.cl implements it (ESTIMATOR = its id).
inline EstimatorInfo study_entry(Estimator id, const char* name, const char* draws, unsigned needs,
                                 StudyStrategy study, bool kernel) {
  EstimatorInfo e = render_entry(id, name, draws, needs, PathStrategy{});
  e.device_id = kernel ? int(id) : -1;
  e.study = study;
  return e;
}

// The renderer's part: the material's technique draws, light samples joining it or not.
inline PathStrategy path_part(BsdfSampler technique, bool light_sampling) {
  PathStrategy r;
  r.renders = true;
  r.technique = technique;
  r.light_sampling = light_sampling;
  return r;
}

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
