// What a sweep fits: the slices of a table, read from its file or computed in memory
// (a lighting's cells, a renderer's tabulation). The sweep sees only a grid and the
// integrand weights of each slice.
#pragma once

#include <vector>

#include "io/table.hpp"
#include "sweep/slice_plan.hpp"

namespace bsdfmix {

// What a sweep fits: the slices of a table, on disk or computed in memory.
class SliceSource {
 public:
  virtual ~SliceSource() = default;
  // The grid: domain, azimuthal, theta_o/phi_o (which index the slices), theta_i, phi_i, source.
  virtual const TableMeta& meta() const = 0;
  // The integrand weights of one slice, row-major [theta_i][phi_i], as integrand_weights()
  // gives them for a table (f * [cos theta_i] * J * cell area).
  virtual std::vector<double> weights(const SliceRef& ref) const = 0;
  // With meta().rgb, the integrand weights of the R, G and B channels of one slice, the same
  // integrand per channel: channel-major [3][theta_i][phi_i], of any sign (measured channels
  // dip below zero where they are noise). The stand-in's rgb_scale is fitted to them.
  // Without rgb (the default) there are none: InputError.
  virtual std::vector<double> rgb_weights(const SliceRef& ref) const;
};

// The slices of a table file.
class TableSlices final : public SliceSource {
 public:
  explicit TableSlices(const TableReader& reader);
  const TableMeta& meta() const override;
  std::vector<double> weights(const SliceRef& ref) const override;
  std::vector<double> rgb_weights(const SliceRef& ref) const override;

 private:
  const TableReader& reader_;
};

}  // namespace bsdfmix
