// The slices of a table file, as a sweep fits them.
#include "sweep/slice_source.hpp"

#include <cmath>

#include "core/domain.hpp"
#include "core/error.hpp"

namespace bsdfmix {

std::vector<double> SliceSource::rgb_weights(const SliceRef& ref) const {
  throw InputError("slice " + std::to_string(ref.index) + ": the slices have no rgb channels");
}

TableSlices::TableSlices(const TableReader& reader) : reader_(reader) {}

const TableMeta& TableSlices::meta() const { return reader_.meta(); }

std::vector<double> TableSlices::weights(const SliceRef& ref) const {
  const TableMeta& m = reader_.meta();
  const std::vector<float> f = reader_.read_slice(ref.t_o, ref.p_o);
  return integrand_weights(m.domain, m.theta_i, m.phi_i, f.data());
}

std::vector<double> TableSlices::rgb_weights(const SliceRef& ref) const {
  const TableMeta& m = reader_.meta();
  const std::vector<float> rgb = reader_.read_slice_rgb(ref.t_o, ref.p_o);  // [cell][channel]
  const std::size_t n = m.cells_per_slice();
  std::vector<double> out;
  out.reserve(3 * n);
  std::vector<float> channel(n);
  for (int c = 0; c < 3; ++c) {
    for (std::size_t i = 0; i < n; ++i) {
      channel[i] = rgb[3 * i + std::size_t(c)];
      if (!std::isfinite(channel[i]))
        throw InputError(reader_.path() + ": /table/rgb slice " + std::to_string(ref.index) + " cell (theta_i " +
                         std::to_string(i / m.phi_i.size()) + ", phi_i " + std::to_string(i % m.phi_i.size()) +
                         ", channel " + std::to_string(c) + "): not finite");
    }
    const std::vector<double> w = integrand_weights(m.domain, m.theta_i, m.phi_i, channel.data());
    out.insert(out.end(), w.begin(), w.end());
  }
  return out;
}

}  // namespace bsdfmix
