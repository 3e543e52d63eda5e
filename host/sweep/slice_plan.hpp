// Which slices a sweep fits: every slice of the table, or the slices a scene needs
// (the grid slices that serve its omega_o directions by interpolation).
#pragma once

#include <cstddef>
#include <vector>

#include "io/table.hpp"

namespace bsdfmix {

struct SliceRef {
  std::size_t index;  // t_o * n_phi_o + p_o
  std::size_t t_o, p_o;
};

// All slices when `theta_o` is empty; otherwise, for each requested (theta_o, phi_o)
// (phi_o ignored with azimuthal symmetry; an empty phi_o list means 0), the 2 (or 4)
// grid slices around it. Sorted by index, without repeats.
std::vector<SliceRef> plan_slices(const TableMeta& meta, const std::vector<double>& theta_o,
                                  const std::vector<double>& phi_o);

}  // namespace bsdfmix
