// The BxDF a path vertex integrates: f and the estimator's draw.
#include "render/bxdf.hpp"

namespace bsdfmix {
namespace render {

SampledBxdf::SampledBxdf(const TableBsdf& m, FSource f, const PathStrategy& s)
    : m_(&m), f_(f), table_(m), stand_in_(m), rgl_(m), uniform_(m), own_(s.sampler) {
  switch (s.technique) {
    case BsdfSampler::Uniform: draw_ = &uniform_; break;
    case BsdfSampler::Mixture: draw_ = &stand_in_; break;
    case BsdfSampler::TableCdf: draw_ = &table_; break;
    case BsdfSampler::Rgl: draw_ = &rgl_; break;
  }
}

}  // namespace render
}  // namespace bsdfmix
