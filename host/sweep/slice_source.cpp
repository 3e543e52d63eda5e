// The slices of a table file, as a sweep fits them.
#include "sweep/slice_source.hpp"

#include "core/domain.hpp"

namespace bsdfmix {

TableSlices::TableSlices(const TableReader& reader) : reader_(reader) {}

const TableMeta& TableSlices::meta() const { return reader_.meta(); }

std::vector<double> TableSlices::weights(const SliceRef& ref) const {
  const TableMeta& m = reader_.meta();
  const std::vector<float> f = reader_.read_slice(ref.t_o, ref.p_o);
  return integrand_weights(m.domain, m.theta_i, m.phi_i, f.data());
}

}  // namespace bsdfmix
