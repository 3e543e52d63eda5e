// mis_tab: the mixture with a defensive share of uniform samples (balance heuristic), the
// table's f (kernels/sample.cl ESTIMATOR 4); in the renderer the BSDF draw alone.
#include "sampling/draws.hpp"
#include "sampling/estimator_builtins.hpp"

namespace bsdfmix {
namespace {

using namespace draws;

double estimate(const Problem& p, const double u[4]) {
  const Domain d = p.table.domain;
  const double a = p.mis.uniform_fraction;
  double th, ph;
  if (u[0] < a) {
    uniform_draw(d, u[2], u[3], th, ph);
  } else {
    const mix::Sample s = p.set->sample(p.theta_o, p.phi_o, (u[0] - a) / (1 - a), u[1], u[2], u[3]);
    if (!(s.theta >= theta_lo(d) && s.theta <= theta_hi(d))) return 0;
    th = s.theta;
    ph = s.phi;
  }
  const double f = p.table.f_at(th, ph);
  if (f == 0) return 0;
  const double pdf = a * uniform_pdf(d) + (1 - a) * p.set->pdf_omega(p.theta_o, p.phi_o, th, ph);
  if (!(pdf > 0)) return 0;
  return p.light.radiance(th, ph) * f * cos_factor(d, th) / pdf;
}

double pdf(const Problem& p, double th, double ph) {
  return p.mis.uniform_fraction * uniform_pdf(p.table.domain) +
         (1 - p.mis.uniform_fraction) * p.set->pdf_omega(p.theta_o, p.phi_o, th, ph);
}

bool draw(const Problem& p, const double u[4], double& th, double& ph) {
  const Domain d = p.table.domain;
  const double a = p.mis.uniform_fraction;
  if (u[0] < a) {
    uniform_draw(d, u[2], u[3], th, ph);
    return true;
  }
  const mix::Sample s = p.set->sample(p.theta_o, p.phi_o, (u[0] - a) / (1 - a), u[1], u[2], u[3]);
  th = s.theta;
  ph = s.phi;
  return inside(d, th);
}

}  // namespace

EstimatorInfo builtin::mis_tab() {
  EstimatorInfo e = study_entry(Estimator::MisTab, "mis_tab", "mixture + uniform", 0, {estimate, pdf, draw}, true);
  e.render = path_part(BsdfSampler::Mixture, false);
  return e;
}

}  // namespace bsdfmix
