// mis_light_rgl: light sampling and the RGL file's warps by one-sample MIS, as
// mis_light_cdf combines the table CDF with it; no kernel: the study runs it on the CPU.
#include "sampling/draws.hpp"
#include "sampling/estimator_builtins.hpp"

namespace bsdfmix {
namespace {

using namespace draws;

// light, the RGL file's warps
bool draw_k(const Problem& p, int k, double r0, const double u[4], double& th, double& ph) {
  if (k == 0) {
    light_draw(p, r0, u[1], u[2], u[3], th, ph);
    return true;
  }
  return rgl_draw(p, u[1], u[2], th, ph);
}

void pdfs(const Problem& p, double th, double ph, double* pdf) {
  pdf[0] = light_pdf(p, th, ph);
  pdf[1] = rgl_pdf(p, th, ph);
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

EstimatorInfo builtin::mis_light_rgl() {
  EstimatorInfo e;
  e.name = "mis_light_rgl";
  e.draws = "light + RGL warps";
  e.needs = kNeedsLighting | kNeedsRgl;
  e.study = {estimate, pdf, nullptr};
  e.render.renders = true;
  e.render.technique = BsdfSampler::Rgl;
  e.render.light_sampling = true;
  e.id = Estimator::MisLightRgl;
  return e;
}

}  // namespace bsdfmix
