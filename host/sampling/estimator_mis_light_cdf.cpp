// mis_light_cdf: light sampling and the table CDF by one-sample MIS (kernels/sample.cl
// ESTIMATOR 7); in the renderer the table CDF's draw with light samples by MIS.
#include "sampling/draws.hpp"
#include "sampling/estimator_builtins.hpp"

namespace bsdfmix {
namespace {

using namespace draws;

// light, table CDF
MisTechniques techniques(const Problem& p) {
  return {2, {p.mis.light_fraction, 1 - p.mis.light_fraction, 0}, {&kLightTechnique, &kCdfTechnique, nullptr}};
}

}  // namespace

EstimatorInfo builtin::mis_light_cdf() {
  EstimatorInfo e = study_entry(Estimator::MisLightCdf, "mis_light_cdf", "light + table CDF", kNeedsLighting,
                                {draws::mis_estimate_of<techniques>, draws::mis_pdf_of<techniques>, nullptr}, true);
  e.render = path_part(BsdfSampler::TableCdf, true);
  return e;
}

}  // namespace bsdfmix
