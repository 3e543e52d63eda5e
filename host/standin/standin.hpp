// `bsdfmix standin TABLE --target E` (docs/fitting.md, "A stand-in chosen by its
// target"): the smallest stand-in whose error, measured as `bsdfmix compare` measures it
// at every table slice, meets a target, within an optional byte budget.
//
// Slices are fitted independently, so each K cap is fitted once on every table row (caps
// in increasing order, `extra_caps` past the first whose every-row candidate meets); a
// candidate of theta_o stride s is the subset of that fit on stride_rows (the first and
// last row included), exactly the file a fit with `theta_o_stride: s` writes. Each
// candidate is packed ragged_f32 and compared with the table at every slice.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "sweep/fit_settings.hpp"

namespace bsdfmix {

struct StandinOptions {
  std::string table, output, work;  // work: the fits and candidate files (resumable)
  double target = 0.05;             // the error to meet, a fraction
  bool p90 = false;                 // the metric: the median (false) or the p90 over the table slices
  std::uint64_t max_bytes = 0;      // payload bytes at most; 0: no budget
  std::vector<int> k_caps;          // increasing
  // caps fitted past the first at which every row meets the target (a larger K can let a
  // coarser stride meet it in fewer bytes); then raising stops
  int extra_caps = 1;
  std::vector<int> strides;         // theta_o strides tried at each cap
  FitSettings fit;                  // the fit settings (k_max and the slices are set per cap)
  std::string device;
};

struct StandinCandidate {
  int stride = 1, k_cap = 1;
  std::size_t rows = 0;                       // theta_o rows fitted
  std::uint64_t bytes = 0, file_bytes = 0;    // payload (as `pack` counts it) and file, ragged_f32
  double median = 0, p90 = 0;                 // the error over every table slice
  double fit_seconds = 0;                     // the all-rows fit's seconds times the share of rows kept
  std::string path;                           // the candidate's file in the work directory
};

struct StandinResult {
  bool rgb = false;  // the error is the RGB error less its negative share (else the luminance L1)
  std::vector<StandinCandidate> candidates;
  std::optional<std::size_t> chosen;   // meets the target within the budget, the fewest bytes
  std::size_t closest = 0;             // without a choice: the least error (within the budget if any is)
  std::string why;                     // one line: what was chosen and why, or what was missed
};

// The work directory beside `output` when none is given: "<output without .h5>.standin".
std::string default_work_dir(const std::string& output);

// Fits, measures and chooses; writes nothing to `output` (write_stand_in does).
StandinResult choose_stand_in(const StandinOptions& o);

// The candidates as an aligned text table (one row each, the chosen one marked) and as CSV
// (docs/formats.md, "Stand-in candidates").
std::string candidates_table(const StandinResult& r);
std::string candidates_csv(const StandinResult& r);

// The chosen candidate's file copied to `output` (atomically).
void write_stand_in(const StandinResult& r, const std::string& output);

}  // namespace bsdfmix
