// The fitting sweep of `bsdfmix fit`: for every slice it needs, search the Gaussian
// count, fit the chosen K thoroughly, and write the mixture file, the fit report and
// the search CSVs. Batches of slices are committed as they finish (sweep/checkpoint.hpp).
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "config/config.hpp"

namespace bsdfmix {

struct SweepSummary {
  bool complete = true;  // false: stopped at max_batches, outputs not written yet
  std::size_t slices = 0, resumed = 0, failed = 0;
  std::map<int, std::size_t> k_histogram;
  double l1_median = 0, l1_p90 = 0, l1_max = 0;
  std::uint64_t mixture_bytes = 0;   // parameters stored (DESIGN.md payload)
  std::uint64_t table_bytes = 0;     // the fitted slices as the table stores them (float32)
  std::uint64_t full_bytes = 0;      // the full 4D float32 table those slices stand for
  double seconds = 0;
  std::string devices;
  std::string text() const;          // the printed summary
};

// Fits the slices `fit` asks for. With `max_batches`, stops after committing that many
// batches (the summary's `complete` is false and no final file is written): a later run
// resumes from the checkpoint.
SweepSummary run_sweep(const std::string& table_path, const FitSection& fit, const std::string& device_selector,
                       std::size_t max_batches = SIZE_MAX);

}  // namespace bsdfmix
