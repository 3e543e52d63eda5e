// is_rgl: the RGL file's own warps (tables/rgl_brdf.hpp), the table's f; no kernel: the
// study runs it on the CPU.
#include "sampling/draws.hpp"
#include "sampling/estimator_builtins.hpp"

namespace bsdfmix {
namespace {

using namespace draws;

double estimate(const Problem& p, const double u[4]) {
  double th, ph, pdf = 0;
  if (!rgl_draw(p, u[1], u[2], th, ph, &pdf)) return 0;
  return table_weight(p, th, ph, pdf);
}

bool draw(const Problem& p, const double u[4], double& th, double& ph) { return rgl_draw(p, u[1], u[2], th, ph); }

}  // namespace

EstimatorInfo builtin::is_rgl() {
  EstimatorInfo e = study_entry(Estimator::IsRgl, "is_rgl", "RGL warps", kNeedsRgl, {estimate, draws::rgl_pdf, draw}, false);
  e.render = path_part(BsdfSampler::Rgl, false);
  return e;
}

}  // namespace bsdfmix
