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
MisTechniques techniques(const Problem& p) {
  const MisOptions& m = p.mis;
  return {3, {m.product_fraction, m.product_light, 1 - m.product_fraction - m.product_light},
          {&kProductTechnique, &kLightTechnique, &kUniformTechnique}};
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
