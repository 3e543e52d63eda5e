// mis_product: the product of the BSDF mixture and the lighting's mixture, light sampling
// and uniform by one-sample MIS (kernels/sample.cl ESTIMATOR 10); in the renderer the
// mixture's draw with light samples, a share of them from the per-vertex product
// (render/fast_product.hpp), by MIS.
#include "sampling/draws.hpp"
#include "sampling/estimator_builtins.hpp"

namespace bsdfmix {
namespace {

using namespace draws;

// product, light, uniform
bool draw_k(const Problem& p, int k, double r0, const double u[4], double& th, double& ph) {
  if (k == 1) {
    light_draw(p, r0, u[1], u[2], u[3], th, ph);
  } else if (k == 2) {
    uniform_draw(p.table.domain, u[2], u[3], th, ph);
  } else {
    const mix::Sample s = p.product.sample(p.table.domain, u[1], u[2], u[3]);
    th = s.theta;
    ph = s.phi;
  }
  return true;
}

void pdfs(const Problem& p, double th, double ph, double* pdf) {
  const Domain d = p.table.domain;
  const bool in = inside(d, th);
  pdf[0] = in ? p.product.pdf_omega(d, th, ph) : 0;
  pdf[1] = light_pdf(p, th, ph);
  pdf[2] = in ? uniform_pdf(d) : 0;
}

MisTechniques techniques(const Problem& p) {
  const MisOptions& m = p.mis;
  return {3, {m.product_fraction, m.product_light, 1 - m.product_fraction - m.product_light}, draw_k, pdfs};
}

double estimate(const Problem& p, const double u[4]) { return p.has_product ? mis_estimate(p, techniques(p), u) : 0; }

}  // namespace

EstimatorInfo builtin::mis_product() {
  EstimatorInfo e = study_entry(Estimator::MisProduct, "mis_product", "product + light + uniform",
                                kNeedsLighting | kNeedsProduct, {estimate, draws::mis_pdf_of<techniques>, nullptr}, true);
  e.render = path_part(BsdfSampler::Mixture, true);
  e.render.product = true;
  return e;
}

}  // namespace bsdfmix
