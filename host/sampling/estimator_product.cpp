// product: the product of the BSDF mixture and the lighting's fitted mixture, the table's f
// (kernels/sample.cl ESTIMATOR 9).
#include "sampling/draws.hpp"
#include "sampling/estimator_builtins.hpp"

namespace bsdfmix {
namespace {

using namespace draws;

double estimate(const Problem& p, const double u[4]) {
  if (!p.has_product) return 0;
  const mix::Sample s = p.product.sample(p.table.domain, u[1], u[2], u[3]);
  if (!s.valid) return 0;
  const double f = p.table.f_at(s.theta, s.phi);
  if (f == 0) return 0;
  return p.light.radiance(s.theta, s.phi) * f * cos_factor(p.table.domain, s.theta) / s.pdf_omega;
}

double pdf(const Problem& p, double th, double ph) {
  return p.has_product ? p.product.pdf_omega(p.table.domain, th, ph) : 0;
}

bool draw(const Problem& p, const double u[4], double& th, double& ph) {
  if (!p.has_product) return false;
  const mix::Sample s = p.product.sample(p.table.domain, u[1], u[2], u[3]);
  th = s.theta;
  ph = s.phi;
  return s.valid;
}

}  // namespace

EstimatorInfo builtin::product() {
  return study_entry(Estimator::Product, "product", "product", kNeedsLighting | kNeedsProduct, {estimate, pdf, draw},
                     true);
}

}  // namespace bsdfmix
