// The in-memory entry to the sweep: a set of slices in, their mixtures and the rows of
// the fit report and search CSVs out; no files, no checkpoint. run_sweep (sweep/sweep.hpp)
// fits its batches with the same batch fitter, so both give the same mixtures. And over
// it, the fit on demand of a caller that keeps its mixtures in the fit's output files
// (fit_slices_kept: the render's).
#pragma once

#include <cstddef>
#include <limits>
#include <string>
#include <vector>

#include "sweep/fit_settings.hpp"
#include "sweep/fit_phases.hpp"
#include "device/device.hpp"
#include "fit/em.hpp"
#include "io/mixture_file.hpp"
#include "sweep/slice_plan.hpp"
#include "sweep/slice_source.hpp"

namespace bsdfmix {

struct ReportRow {  // one row of the fit report (docs/formats.md, "Fit report")
  std::size_t slice = 0;
  double theta_o = 0, phi_o = 0;
  int k = 0, iterations = 0;
  double loglik = 0, l1_rel = 0, seconds = 0;
  std::string device, status;  // status: ok / zero: ... / reduced: ... / failed: ...
  // The stand-in's RGB error and the part of it in cells whose measured channel is
  // negative (sweep/fit_error.hpp StandInError); NaN for a table without rgb.
  double rgb_l1_rel = std::numeric_limits<double>::quiet_NaN(), rgb_negative = std::numeric_limits<double>::quiet_NaN();
  // The uniform share the slice earns and the largest importance weight with it, over the
  // integral (sweep/earned_share.hpp).
  double defensive = 0.1, max_weight = 0;
  bool failed() const;
};

// One row of the Gaussian-count search CSV (docs/formats.md, "Gaussian-count search").
struct SearchRow {
  std::size_t slice = 0;
  int k = 0, restart = 0;
  double loglik = 0, l1_rel = 0, score = 0;
  bool chosen = false;
};

struct SweepResult {
  MixtureFile mixture;                   // the fitted slices in slice-index order; domain, azimuthal, table_source,
                                         // fit_settings (fit_settings_json), table_theta_o/phi_o filled
  std::vector<std::size_t> slice_index;  // table slice index of each mixture slice
  std::vector<ReportRow> report;         // one per slice, same order
  std::vector<SearchRow> search;
  FitPhases phases;  // where the fits' time went (fit_slices: summed over its batches)
  std::size_t failed() const;
};

// Fits `slices` of `source` (sorted, unique) with the settings of `fit` (its output paths,
// theta_o and phi_o are not read) on `devices`, in the same batches as run_sweep, so the
// mixtures are the same as the file sweep's, the engine run as `engine` says. Prints a
// progress line labelled `what`.
SweepResult fit_slices(const SliceSource& source, const std::vector<SliceRef>& slices, const FitSettings& fit,
                       const std::vector<Device>& devices, const std::string& what, const EngineOptions& engine = {});

// The mixtures of `slices` of `source` (sorted, unique), kept in fit.output for the next
// caller: read from there when it holds them fitted to this table (the same
// meta().source) with the same settings (fit_settings_match): as it is when it holds
// exactly those slices, else those taken out of it (a sweep of every slice serves any
// subset); else fitted on the devices of `device_selector` and written there with the fit
// report and search CSVs by the sweep's outputs (write_outputs; `table_path`: the table
// file whose sizes they report), the engine run as `engine` says. A fit of the same output
// elsewhere fails at once (its lock). Log lines begin with `who`.
MixtureFile fit_slices_kept(const SliceSource& source, const std::string& table_path,
                            const std::vector<SliceRef>& slices, const FitSettings& fit,
                            const std::string& device_selector, const std::string& who,
                            const EngineOptions& engine = {});

// Whether the fit settings a mixture file records (its fit_settings attribute, the text
// of fit_settings_json) are those of `fit`, compared as typed values: every setting the
// record holds, at the precision it holds them. False for a text that is not such a record.
bool fit_settings_match(const std::string& recorded, const FitSettings& fit);

}  // namespace bsdfmix
