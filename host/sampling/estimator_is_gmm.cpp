// is_gmm: the mixture's own sampler, the stand-in's f (kernels/sample.cl ESTIMATOR 3).
#include "sampling/draws.hpp"
#include "sampling/estimator_builtins.hpp"

namespace bsdfmix {
namespace {

using namespace draws;

double estimate(const Problem& p, const double u[4]) {
  const mix::Sample s = p.set->sample(p.theta_o, p.phi_o, u[0], u[1], u[2], u[3]);
  if (!s.valid) return 0;
  const double f = p.set->eval_f(p.theta_o, p.phi_o, s.theta, s.phi);
  if (f == 0) return 0;
  return p.light.radiance(s.theta, s.phi) * f * cos_factor(p.table.domain, s.theta) / s.pdf_omega;
}

double pdf(const Problem& p, double th, double ph) { return p.set->pdf_omega(p.theta_o, p.phi_o, th, ph); }

bool draw(const Problem& p, const double u[4], double& th, double& ph) {
  const mix::Sample s = p.set->sample(p.theta_o, p.phi_o, u[0], u[1], u[2], u[3]);
  th = s.theta;
  ph = s.phi;
  return s.valid;
}

}  // namespace

EstimatorInfo builtin::is_gmm() {
  EstimatorInfo e;
  e.name = "is_gmm";
  e.draws = "mixture";
  e.needs = kStandInF;
  e.device_id = int(Estimator::IsGmm);
  e.study = {estimate, pdf, draw};
  e.id = Estimator::IsGmm;
  return e;
}

}  // namespace bsdfmix
