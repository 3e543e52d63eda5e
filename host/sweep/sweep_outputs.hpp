// What a file sweep leaves behind: the mixture file, the fit report and search CSVs
// and its summary; and the fingerprint that makes its checkpoint reusable.
#pragma once

#include <string>
#include <vector>

#include "sweep/fit_settings.hpp"
#include "device/device.hpp"
#include "fit/em.hpp"
#include "io/table.hpp"
#include "sweep/fit_slices.hpp"
#include "sweep/slice_plan.hpp"
#include "sweep/sweep.hpp"

namespace bsdfmix {

// The CSV texts of the fit report and the search (docs/formats.md, "CSV files"), header included.
std::string report_csv(const std::vector<ReportRow>& rows);
std::string search_csv(const std::vector<SearchRow>& rows);

// Writes fit.output, fit.report and fit.search_report from `result` (atomically) and
// sums them up (sizes against the table at `table_path`); resumed, seconds and devices
// are left to the caller.
SweepSummary write_outputs(const SweepResult& result, const std::string& table_path, const TableMeta& meta,
                           const FitSettings& fit);

// What makes a checkpoint reusable: the table (path, size, source; its content is
// checked part by part), the slices planned and the batching, every fit setting, the
// build (the executable's and the EM kernel's bytes) and the numeric path (devices,
// drivers, precision).
std::string sweep_fingerprint(const std::string& table_path, const TableMeta& meta, const std::vector<SliceRef>& plan,
                              const FitSettings& fit, std::size_t batch, const EmEngine& engine,
                              const std::vector<Device>& devices);

}  // namespace bsdfmix
