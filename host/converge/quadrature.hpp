// The convergence study's exact integrals by quadrature (what each estimator converges to;
// the CSVs' `reference` column) and the per-slice tail-risk diagnostic.
#pragma once

#include <vector>

#include "sampling/sampling.hpp"

namespace bsdfmix {

// Gauss-Legendre nodes and weights on [-1, 1].
void gauss_legendre(int n, std::vector<double>& nodes, std::vector<double>& weights);

// The integral of L_i f c d(omega) with the table as f (piecewise constant over its
// cells): exact cell Jacobian integrals for constant L, sub-cell Gauss-Legendre otherwise.
double table_integral(const Problem& p);

// The same with the mixture stand-in as f: what us_gmm and is_gmm converge to. Exact
// (normal CDFs of the theta marginals) for constant L, quadrature otherwise.
double stand_in_integral(const Problem& p);

// Tail risk of importance sampling the table with the mixture, with L_i = 1 and the
// cell probabilities of each technique: the relative variance per sample
// (sum_c (W_c / I)^2 / P_c - 1, the chi-square divergence of the sampling density from
// the integrand) and the largest single-sample weight (max_c (W_c / I) / P_c).
// Cells where the mixture's density is exactly zero (past its 9-sigma cut, or underflow)
// are never sampled by is_tab: they add no variance but bias it by -missed_is, the share
// of the integral they hold. They are left out of relvar_is and max_weight_is, which stay
// finite.
struct TailDiagnostic {
  double reference = 0, stand_in = 0;
  double relvar_us = 0, relvar_is = 0, relvar_mis = 0, relvar_cdf = 0;
  double max_weight_is = 0, max_weight_mis = 0;
  double missed_is = 0;
};
TailDiagnostic tail_diagnostic(const Problem& p);

// The same diagnostic under the scene's lighting, for any estimators: per table cell c,
// W_c = the integral of L f c d(omega) over the cell (sub-cell Gauss-Legendre) and P_e,c
// = the integral of estimator e's density (estimator_pdf) over it. relvar_e = sum_c
// (W_c / I)^2 / P_e,c - 1, max_weight_e = max_c (W_c / I) / P_e,c, missed_e = the share of
// the integral in cells e never samples (left out of the other two).
struct LightTail {
  double reference = 0;
  std::vector<double> relvar, max_weight, missed;  // per estimator
};
LightTail light_tail(const Problem& p, const std::vector<Estimator>& estimators);

// mis_product's fractions chosen from the same cell probabilities: among product shares
// 0.5 .. 0.98 (the rest split between light and uniform sampling), the one of least
// predicted relative variance whose largest weight f/pdf over the integral stays within
// `max_weight_bound` (if none does, the one with the smallest largest weight). The choice
// depends on the problem only, never on the samples, so the estimator stays unbiased.
struct ProductTuning {
  double product_fraction = 0.8, product_light = 0.1;
  double relvar = 0, max_weight = 0;  // predicted, of the choice
  bool bounded = false;               // max_weight <= the bound
};
ProductTuning tune_product_fractions(const Problem& p, double max_weight_bound = 10.0);

}  // namespace bsdfmix

