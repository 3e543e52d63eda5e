// us_tab: uniform sampling over the domain, the table's f (kernels/sample.cl ESTIMATOR 0).
#include "sampling/draws.hpp"
#include "sampling/estimator_builtins.hpp"

namespace bsdfmix {
namespace {

using namespace draws;

double estimate(const Problem& p, const double u[4]) {
  const Domain d = p.table.domain;
  double th, ph;
  uniform_draw(d, u[2], u[3], th, ph);
  const double f = p.table.f_at(th, ph);
  if (f == 0) return 0;
  return p.light.radiance(th, ph) * f * cos_factor(d, th) / uniform_pdf(d);
}

double pdf(const Problem& p, double, double) { return uniform_pdf(p.table.domain); }

bool draw(const Problem& p, const double u[4], double& th, double& ph) {
  uniform_draw(p.table.domain, u[2], u[3], th, ph);
  return true;
}

}  // namespace

EstimatorInfo builtin::us_tab() {
  EstimatorInfo e;
  e.name = "us_tab";
  e.draws = "uniform";
  e.device_id = int(Estimator::UsTab);
  e.study = {estimate, pdf, draw};
  e.id = Estimator::UsTab;
  return e;
}

}  // namespace bsdfmix
