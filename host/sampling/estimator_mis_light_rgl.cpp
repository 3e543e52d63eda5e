// mis_light_rgl: light sampling and the RGL file's warps by one-sample MIS, as
// mis_light_cdf combines the table CDF with it; no kernel: the study runs it on the CPU.
#include "sampling/draws.hpp"
#include "sampling/estimator_builtins.hpp"

namespace bsdfmix {
namespace {

using namespace draws;

// light, the RGL file's warps
MisTechniques techniques(const Problem& p) {
  return {2, {p.mis.light_fraction, 1 - p.mis.light_fraction, 0}, {&kLightTechnique, &kRglTechnique, nullptr}};
}

}  // namespace

EstimatorInfo builtin::mis_light_rgl() {
  EstimatorInfo e = study_entry(Estimator::MisLightRgl, "mis_light_rgl", "light + RGL warps", kNeedsLighting | kNeedsRgl,
                                {draws::mis_estimate_of<techniques>, draws::mis_pdf_of<techniques>, nullptr}, false);
  e.render = path_part(BsdfSampler::Rgl, true);
  return e;
}

}  // namespace bsdfmix
