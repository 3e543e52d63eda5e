// Which slices a sweep fits: every slice of the table, or the slices a scene needs
// (the grid slices that serve its omega_o directions by interpolation).
#pragma once

#include <cstddef>
#include <vector>

#include "io/table.hpp"
#include "sweep/fit_settings.hpp"

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

// Rows 0, stride, 2 stride, ... of n rows, and always the last (so interpolation covers the
// whole axis); every row for stride <= 1.
std::vector<std::size_t> stride_rows(std::size_t n, std::size_t stride);

// The theta_o rows a fit's theta_o_stride, theta_o_rows and theta_o_deg name (each degree
// value snapped to the nearest row), sorted, without repeats; empty when none is set.
// InputError for a row index past the axis.
std::vector<std::size_t> chosen_rows(const std::vector<double>& theta_o_axis, const FitSettings& fit);

// The slices of a fit: every slice of the chosen rows (all their phi_o) with the slices
// plan_slices gives for fit.theta_o and fit.phi_o; every slice when neither is set.
std::vector<SliceRef> plan_fit_slices(const TableMeta& meta, const FitSettings& fit);

}  // namespace bsdfmix
