// The uniform share each fitted slice earns (docs/sampling.md, "The earned share"): the
// smallest share on a ladder whose largest importance weight on the table's own cells is
// at most kWeightCap times the integral, or no larger than with the fixed share 0.1.
#pragma once

#include <array>

#include "core/domain.hpp"
#include "sweep/fit_error.hpp"

namespace bsdfmix {

// The shares tried, smallest first; the last is the fixed share of files before it.
constexpr std::array<double, 7> kShareLadder = {0.0, 0.002, 0.005, 0.01, 0.02, 0.05, 0.1};

// The largest weight over the integral a slice may take without the share's help: the
// variance per sample is then below (kWeightCap - 1) I^2.
constexpr double kWeightCap = 3.0;

struct EarnedShare {
  double share = 0.1;       // the smallest ladder share a with W(a) <= max(kWeightCap, W(0.1))
  double max_weight = 0.0;  // W(share)
};

// W(a) = max over cells with weight w_i > 0 of w_i / ((1 - a) m_i + a u_i) / I: the
// largest importance weight of mixture-plus-uniform sampling relative to the integral
// I = sum w_i. m_i: the prepared mixture's mass in cell i (cell_masses), u_i: the uniform
// density's (1 / (2 pi) per steradian on the hemisphere, 1 / (4 pi) on the fiber sphere).
// Infinite where a cell with weight gets no mass; 0 for a zero slice.
double max_weight(const WeightedSlice& s, const std::vector<double>& masses, const std::vector<double>& uniform,
                  double share);

// The uniform density's mass in each cell of the slice: its solid angle (J dtheta dphi at
// the cell center) over the domain's.
std::vector<double> uniform_masses(const WeightedSlice& s, Domain d);

// The share slice `s` earns with mixture `m` (prepared). A zero slice earns 0.
EarnedShare earned_share(const WeightedSlice& s, const mix::SliceMixture& m, Domain d);

}  // namespace bsdfmix
