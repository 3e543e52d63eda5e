// light: the light sampler alone, the table's f (kernels/sample.cl ESTIMATOR 6).
#include "sampling/draws.hpp"
#include "sampling/estimator_builtins.hpp"

namespace bsdfmix {
namespace {

using namespace draws;

double estimate(const Problem& p, const double u[4]) {
  const Domain d = p.table.domain;
  double th, ph;
  light_draw(p, u[0], u[1], u[2], u[3], th, ph);
  if (!inside(d, th)) return 0;
  const double f = p.table.f_at(th, ph);
  const double pdf = light_pdf(p, th, ph);
  if (f == 0 || !(pdf > 0)) return 0;
  return p.light.radiance(th, ph) * f * cos_factor(d, th) / pdf;
}

bool draw(const Problem& p, const double u[4], double& th, double& ph) {
  light_draw(p, u[0], u[1], u[2], u[3], th, ph);
  return inside(p.table.domain, th);
}

}  // namespace

EstimatorInfo builtin::light() {
  return study_entry(Estimator::Light, "light", "light", kNeedsLighting, {estimate, draws::light_pdf, draw}, true);
}

}  // namespace bsdfmix
