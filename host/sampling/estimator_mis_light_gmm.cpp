// mis_light_gmm: light sampling, the mixture and uniform by one-sample MIS (kernels/sample.cl
// ESTIMATOR 8); in the renderer the mixture's draw (with its uniform share) with light
// samples by MIS.
#include "sampling/draws.hpp"
#include "sampling/estimator_builtins.hpp"

namespace bsdfmix {
namespace {

using namespace draws;

// light, mixture, uniform
bool draw_k(const Problem& p, int k, double r0, const double u[4], double& th, double& ph) {
  if (k == 0) {
    light_draw(p, r0, u[1], u[2], u[3], th, ph);
  } else if (k == 2) {
    uniform_draw(p.table.domain, u[2], u[3], th, ph);
  } else {
    const mix::Sample s = p.set->sample(p.theta_o, p.phi_o, r0, u[1], u[2], u[3]);
    th = s.theta;
    ph = s.phi;
  }
  return true;
}

void pdfs(const Problem& p, double th, double ph, double* pdf) {
  const Domain d = p.table.domain;
  const bool in = inside(d, th);
  pdf[0] = light_pdf(p, th, ph);
  pdf[1] = in ? p.set->pdf_omega(p.theta_o, p.phi_o, th, ph) : 0;
  pdf[2] = in ? uniform_pdf(d) : 0;
}

MisTechniques techniques(const Problem& p) {
  const MisOptions& m = p.mis;
  return {3, {m.light_fraction, (1 - m.light_fraction) * (1 - m.uniform_fraction), (1 - m.light_fraction) * m.uniform_fraction},
          draw_k, pdfs};
}

}  // namespace

EstimatorInfo builtin::mis_light_gmm() {
  EstimatorInfo e = study_entry(Estimator::MisLightGmm, "mis_light_gmm", "light + mixture + uniform", kNeedsLighting,
                                {draws::mis_estimate_of<techniques>, draws::mis_pdf_of<techniques>, nullptr}, true);
  e.render = path_part(BsdfSampler::Mixture, true);
  return e;
}

}  // namespace bsdfmix
