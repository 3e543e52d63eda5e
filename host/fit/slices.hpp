// The input of the EM fits: slices of integrand weights on one uniform (theta_i, phi_i) grid.
#pragma once

#include <cstddef>
#include <vector>

#include "core/domain.hpp"

namespace bsdfmix {

// Uniform cell centers of theta_i and phi_i; phi covers one full period.
struct SliceGrid {
  Domain domain = Domain::Fiber;
  std::vector<double> theta, phi;
  std::size_t cells() const { return theta.size() * phi.size(); }
};

// Integrand weights per slice, row-major [theta][phi], any positive scale.
struct SliceSet {
  SliceGrid grid;
  std::vector<std::vector<double>> weights;
  // Optional, per slice: the R, G, B integrand weights of the same cells, channel-major
  // [3][theta][phi], any sign (measured channels dip below zero). Only the L1 refinement
  // reads them (fit/l1_refine.hpp); empty: none.
  std::vector<std::vector<double>> rgb;
};

// The grid of `domain` with n_theta x n_phi cells: theta over the domain's range,
// phi over [-pi, pi).
SliceGrid make_slice_grid(Domain domain, std::size_t n_theta, std::size_t n_phi);

// Checks the grid (uniform axes, at least one cell, phi one full period) and that
// every slice has grid.cells() finite, non-negative weights. Throws InputError.
void validate_slices(const SliceSet& set);

}  // namespace bsdfmix
