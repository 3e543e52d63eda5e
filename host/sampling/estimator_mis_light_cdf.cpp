// mis_light_cdf: light sampling and the table CDF by one-sample MIS (kernels/sample.cl
// ESTIMATOR 7); in the renderer the table CDF's draw with light samples by MIS.
#include "sampling/draws.hpp"
#include "sampling/estimator_builtins.hpp"

namespace bsdfmix {
namespace {

using namespace draws;

// light, table CDF
bool draw_k(const Problem& p, int k, double r0, const double u[4], double& th, double& ph) {
  if (k == 0) {
    light_draw(p, r0, u[1], u[2], u[3], th, ph);
    return true;
  }
  return cdf_draw(p, r0, u[1], u[2], u[3], th, ph);
}

void pdfs(const Problem& p, double th, double ph, double* pdf) {
  pdf[0] = light_pdf(p, th, ph);
  pdf[1] = cdf_pdf(p, th, ph);
}

MisTechniques techniques(const Problem& p) {
  MisTechniques t;
  t.n = 2;
  t.c[0] = p.mis.light_fraction;
  t.c[1] = 1 - p.mis.light_fraction;
  t.draw = draw_k;
  t.pdfs = pdfs;
  return t;
}

double estimate(const Problem& p, const double u[4]) { return mis_estimate(p, techniques(p), u); }
double pdf(const Problem& p, double th, double ph) { return mis_pdf(p, techniques(p), th, ph); }

}  // namespace

EstimatorInfo builtin::mis_light_cdf() {
  EstimatorInfo e;
  e.name = "mis_light_cdf";
  e.draws = "light + table CDF";
  e.needs = kNeedsLighting;
  e.device_id = int(Estimator::MisLightCdf);
  e.study = {estimate, pdf, nullptr};
  e.render.renders = true;
  e.render.technique = BsdfSampler::TableCdf;
  e.render.light_sampling = true;
  e.id = Estimator::MisLightCdf;
  return e;
}

}  // namespace bsdfmix
