// The input of the EM fits: slices of integrand weights on one uniform (theta_i, phi_i) grid.
#pragma once

#include <cstddef>
#include <vector>

#include "core/domain.hpp"

namespace bsdfmix {

// Uniform cell centers of theta_i and phi_i; phi covers one full period.
struct SliceGrid {
  Domain domain = Domain::Fiber;
  // The plane the Gaussians live in (docs/fitting.md, "The map"): ThetaPhi, the cells'
  // (theta, phi) themselves; or an equal-area map, each cell at its center's (x, y) there
  // with its solid angle as its area (cell_point, cell_jacobian).
  Map map = Map::ThetaPhi;
  std::vector<double> theta, phi;
  std::size_t cells() const { return theta.size() * phi.size(); }
};

// Cell i (row-major [theta][phi]) as a point of the grid's plane: (theta, phi) on ThetaPhi,
// the map's (x, y) of its center otherwise.
inline void cell_point(const SliceGrid& g, std::size_t i, double& x, double& y) {
  const std::size_t np = g.phi.size();
  x = g.theta[i / np];
  y = g.phi[i % np];
  if (g.map != Map::ThetaPhi) mix::to_map(g.map, x, y, x, y);
}

// The area of cell i in the grid's plane over dtheta dphi: 1 on ThetaPhi; on an equal-area
// map its solid angle's J(theta) (sin theta on the disk, cos theta on the cylinder).
inline double cell_jacobian(const SliceGrid& g, std::size_t i) {
  return g.map == Map::ThetaPhi ? 1.0 : mix::map_jacobian(g.map, g.theta[i / g.phi.size()]);
}

// The grid's cell side in its plane that the covariance floors use: the smaller of dtheta
// and dphi (on the disk a cell is at least 0.7 of that across; on the cylinder the rows
// near the axis are thinner, the floor keeps a component wider than them).
double plane_step(const SliceGrid& g);

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
