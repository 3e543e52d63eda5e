// How well a slice mixture reproduces its slice: relative L1 error of the cell masses,
// and the pooled (coarser) slices the Gaussian-count search runs on.
#pragma once

#include <bsdfmix/mixture.hpp>

#include <cstddef>
#include <vector>

namespace bsdfmix {

// A slice's integrand weights on a uniform (theta, phi) grid of cell centers.
struct WeightedSlice {
  std::vector<double> theta, phi;  // cell centers; phi a full period
  std::vector<double> w;           // row-major [theta][phi]
  mix::Map map = mix::Map::ThetaPhi;  // the plane the mixtures compared with live in
  // With a base taken off (sweep/base_lobe.hpp): the whole slice's total, which l1_rel_error
  // divides by, and the base's excess over the cells, which it adds; 0: none.
  double reference_total = 0, extra_error = 0;
  double total() const;
};

// The slice with blocks of `factor` x `factor` cells merged: centers averaged,
// weights summed. `factor` must divide both axis lengths (else the slice is returned as is).
WeightedSlice pool_slice(const WeightedSlice& s, std::size_t factor);

// A mixture from parameter arrays (weights K, means 2K, covariances 3K), prepared: the header's.
using mix::make_slice_mixture;

// sum_i |w_i - W m_i| / W, W = sum w, m_i the mixture's mass in cell i: the relative L1
// error of the mixture as a stand-in for the slice (0 to 2). m_i is the density at the
// cell center times the cell area (as the table samples f at cell centers), except for
// components narrower than half a cell, which the table cannot resolve: their mean over
// 3 x 3 points of the cell times its area (a component at the covariance floor holds
// most of its mass in one cell; its center density overstates that 2.5x).
double l1_rel_error(const WeightedSlice& s, const mix::SliceMixture& m);

// The probability mass of a prepared mixture (weights summing to 1) in each cell of the
// slice, row-major like s.w: per component as l1_rel_error measures it (density at the
// cell center, or over 3 x 3 points for a component narrower than half a cell), times the
// cell's area; mass past the theta border is lost.
std::vector<double> cell_masses(const WeightedSlice& s, const mix::SliceMixture& m);

// The errors of a slice's stand-in exactly as a renderer evaluates it through the header:
// each component's mass in each cell by the header's density (as l1_rel_error: at the cell
// center, or over 3 x 3 points for a component narrower than half a cell; fit/gmm.hpp
// sub_cell) times its amplitudes as stored (scale * weight; rgb with colour, or the colour
// copies' rgb where the slice has them), every
// Gaussian whole, its mass past the theta border lost, against the table's integrand weights.
struct StandInError {
  double l1_rel = 0;        // sum |w - stand-in| / sum w over the luminance (0 for a zero slice)
  double rgb_l1_rel = 0;    // sum over R, G, B and the cells of |w_c - stand-in_c|, over sum |w_c|
  double rgb_negative = 0;  // the part of rgb_l1_rel in cells whose measured channel is negative
};
// `rgb`: the slice's R, G, B integrand weights, channel-major (SliceSource::rgb_weights);
// empty: no colour, rgb_l1_rel and rgb_negative NaN.
StandInError stand_in_error(const WeightedSlice& s, const std::vector<double>& rgb, const mix::SliceMixture& m);

}  // namespace bsdfmix
