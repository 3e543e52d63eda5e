// The fields of a fit report row and of a Gaussian-count search row, listed once. Every
// encoding of the rows visits them in this order: the report and search CSVs
// (sweep/sweep_outputs.cpp), a checkpoint part's row datasets (sweep/checkpoint.cpp) and
// the MPI farm's wire format (scale/part_codec.cpp).
#pragma once

#include "sweep/fit_slices.hpp"

namespace bsdfmix {

// How a field is written in a CSV cell: numbers with `format` (non-finite ones as 0), NaN
// as an empty cell where `nan_empty`.
struct CsvText {
  const char* format = "%.9g";
  bool nan_empty = false;
};

// Calls visit(name, field, text) for every field of a report row (ReportRow or const
// ReportRow), in column order. The fields are std::size_t, int, double, std::string.
template <class Row, class Visit>
void report_fields(Row& r, Visit&& visit) {
  const CsvText number, colour{"%.9g", true};  // colour: NaN for a table without rgb
  visit("slice", r.slice, number);
  visit("theta_o", r.theta_o, number);
  visit("phi_o", r.phi_o, number);
  visit("k", r.k, number);
  visit("iterations", r.iterations, number);
  visit("loglik", r.loglik, number);
  visit("l1_rel", r.l1_rel, number);
  visit("seconds", r.seconds, CsvText{"%.6f", false});
  visit("device", r.device, number);
  visit("status", r.status, number);
  visit("rgb_l1_rel", r.rgb_l1_rel, colour);
  visit("rgb_negative", r.rgb_negative, colour);
  visit("defensive", r.defensive, number);
  visit("max_weight", r.max_weight, number);
}

// The same for a search row; its fields are std::size_t, int, double, bool.
template <class Row, class Visit>
void search_fields(Row& r, Visit&& visit) {
  const CsvText number;
  visit("slice", r.slice, number);
  visit("k", r.k, number);
  visit("restart", r.restart, number);
  visit("loglik", r.loglik, number);
  visit("l1_rel", r.l1_rel, number);
  visit("score", r.score, number);
  visit("chosen", r.chosen, number);
}

}  // namespace bsdfmix
