// `bsdfmix compare MIXTURE TABLE` (docs/guide_fit.md): the stand-in's
// error against the table at every slice of the table, the slices between fitted ones
// included (blended as the header blends them, thesis eq. 3.7): what a renderer that
// evaluates the mixture file through include/bsdfmix/mixture.hpp gets, cell by cell.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

namespace bsdfmix {

// One table slice against the stand-in. Every error is a sum over the slice's cells of
// |stand-in - table| times the cell's integrand weight (f [cos theta_i] J dtheta dphi)
// over the same sum of |table|, evaluated at the cell centers.
struct SliceComparison {
  std::size_t slice = 0;
  double theta_o = 0, phi_o = 0;
  bool fitted = false;      // the mixture file holds this slice (else it is blended)
  double l1 = 0;            // luminance (`values` against eval_f)
  double l1_rgb[3] = {0, 0, 0};  // per channel (`rgb` against eval_rgb); 0 without `rgb`
  double rgb_error = 0;     // summed over the channels, over the channels' summed |table|
  double negative_share = 0;  // of that sum, the share in cells where the table's channel is negative
  double energy = 0;        // the stand-in's integral over the table's, minus 1 (luminance)
  double energy_rgb[3] = {0, 0, 0};
  // per channel: noise around zero (its negative cells hold more than 0.5% of its absolute
  // sum, the fit's rule, docs/fitting.md "A noisy channel"): no integral the stand-in keeps
  bool noise[3] = {false, false, false};
  // the integral of f [cos theta_i] d omega_i (L_i = 1) on the table's cells: the table's
  // `values` and the stand-in's eval_f (energy = albedo_stand_in / albedo - 1)
  double albedo = 0, albedo_stand_in = 0;
};

// The albedos at a theta_o the user asks for (phi_o the table's first): the stand-in's as
// a renderer sees it (blended or displaced at theta_o), on the table's cells; the table's
// interpolated linearly in theta_o between its rows row_lo and row_hi (one row beyond the
// first or last).
struct AlbedoAt {
  double theta_o = 0;
  std::size_t row_lo = 0, row_hi = 0;
  double theta_lo = 0, theta_hi = 0;  // the two rows' theta_o
  double table = 0, stand_in = 0;
};

struct Comparison {
  bool rgb = false;  // the table has `rgb`
  std::vector<SliceComparison> slices;
  std::vector<AlbedoAt> asked;  // one per theta_o asked for, in order
};

// Compares every slice of `table` with the stand-in of `mixture`, and their albedos at each
// `theta_o` (radians); InputError when the two do not describe the same function (domain,
// symmetry, omega_o axes) or a theta_o lies outside the domain.
Comparison compare_stand_in(const std::string& mixture, const std::string& table,
                            const std::vector<double>& theta_o = {});

// The CSV (docs/formats.md, "Compare") and the printed summary (medians and 90th
// percentiles over all slices, and over the fitted and the blended ones; the albedos'
// ranges and largest difference; the albedos at each theta_o asked for).
std::string comparison_csv(const Comparison& c);
std::string comparison_summary(const Comparison& c);

// The error comparison_summary reports over every table slice, at quantile q (0.5 the
// median, 0.9 the p90): the RGB error less its negative share with `rgb`, else the
// luminance's relative L1.
double comparison_error(const Comparison& c, double q);

}  // namespace bsdfmix
