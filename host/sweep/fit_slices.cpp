// The in-memory entry to the sweep: slices in, mixtures and report rows out.
#include "sweep/fit_slices.hpp"

#include <algorithm>

#include "core/error.hpp"
#include "core/progress.hpp"
#include "sweep/batch_fitter.hpp"

namespace bsdfmix {

bool ReportRow::failed() const { return status.rfind("failed:", 0) == 0; }

std::size_t SweepResult::failed() const {
  return std::size_t(std::count_if(report.begin(), report.end(), [](const ReportRow& r) { return r.failed(); }));
}

SweepResult fit_slices(const SliceSource& source, const std::vector<SliceRef>& slices, const FitSettings& fit,
                       const std::vector<Device>& devices, const std::string& what, const EngineOptions& engine_options) {
  const TableMeta& meta = source.meta();
  for (std::size_t i = 0; i < slices.size(); ++i) {
    const SliceRef& r = slices[i];
    if (r.t_o >= meta.theta_o.size() || r.p_o >= meta.phi_o.size() || r.index != meta.slice_index(r.t_o, r.p_o))
      throw Error(what + ": slice " + std::to_string(r.index) + " (" + std::to_string(r.t_o) + ", " +
                  std::to_string(r.p_o) + ") is not a slice of the grid");
    if (i > 0 && !(slices[i - 1].index < r.index))
      throw Error(what + ": the slices to fit must be sorted by index, without repeats");
  }
  EmEngine engine(devices, 1, engine_options);
  BatchFitter fitter(source, fit, engine, joined_names(devices));
  SweepResult result = empty_result(meta, fit);
  Progress progress(what, slices.size(), "slices");
  for (const std::vector<SliceRef>& batch : split_batches(slices, batch_size(slices.size(), fit))) {
    append_part(result, fitter.fit(batch));
    progress.advance(batch.size());
  }
  progress.finish();
  return result;
}

}  // namespace bsdfmix
