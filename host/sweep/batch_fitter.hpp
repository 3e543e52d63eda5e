// The fitter of a sweep's batches, shared by the file sweep (run_sweep, its farm and
// its workers) and the in-memory entry (fit_slices): a batch's result depends only on
// its slices and the settings, so every path gives the same mixtures.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "sweep/fit_settings.hpp"
#include "core/hash.hpp"
#include "device/device.hpp"
#include "fit/em.hpp"
#include "sweep/checkpoint.hpp"
#include "sweep/fit_slices.hpp"
#include "sweep/slice_plan.hpp"
#include "sweep/slice_source.hpp"

namespace bsdfmix {

struct Batch;

class BatchFitter {
 public:
  // `source`, `fit` and `engine` must outlive the fitter; `device_names` fills the
  // report's `device` column.
  BatchFitter(const SliceSource& source, const FitSettings& fit, EmEngine& engine, std::string device_names);

  // Searches the Gaussian count of every slice of `refs` (fit.search), fits the chosen K
  // thoroughly, stands a moment-matched Gaussian in where every fit failed; the part
  // holds their mixtures, report and search rows and the weights' content hash.
  BatchPart fit(const std::vector<SliceRef>& refs);

 private:
  void load(Batch& b, const std::vector<SliceRef>& refs, BatchPart& part) const;
  void finish(Batch& b, double seconds, BatchPart& part) const;

  const SliceSource& source_;
  const FitSettings& fit_;
  EmEngine& engine_;
  const std::string devices_;
};

// The map a fit of a `d` table with these settings works and writes in (fit.map); fit.map
// auto on the hemisphere must be chosen first (sweep/map_choice.hpp): std::logic_error.
Map fit_map(const FitSettings& fit, Domain d);

// Cells a default batch holds at most: a batch's memory is about 230 bytes a cell (64
// slices of 90 x 180 cells, about 230 MiB).
constexpr std::size_t kBatchCells = std::size_t(1) << 20;

// Slices per batch of a sweep of `planned` slices of `cells_per_slice` cells: fit.batch,
// or by default 1/32 of the plan within [4, 64], and at most kBatchCells cells (at least
// one slice).
std::size_t batch_size(std::size_t planned, const FitSettings& fit, std::size_t cells_per_slice = 0);

// The batches of a plan: fixed ranges of `batch` slices, so that a resumed sweep
// rebuilds exactly the batches it did not commit.
std::vector<std::vector<SliceRef>> split_batches(const std::vector<SliceRef>& plan, std::size_t batch);

// The devices a sweep runs on, as the report's `device` column names them.
std::string joined_names(const std::vector<Device>& devices);

// Adds one slice's integrand weights to a content hash (BatchPart::slices_hash is
// that of its slices, in order, each with its rgb weights after when the source has them).
void hash_weights(Hash64& content, const std::vector<double>& w);
// That hash of the slices `refs` of `source`.
std::string slices_hash(const SliceSource& source, const std::vector<const SliceRef*>& refs);

// A sweep result of `meta` under `fit` with no slices yet: the mixture's header set.
SweepResult empty_result(const TableMeta& meta, const FitSettings& fit);
// Appends a part's slices and rows (parts in slice order make the result in slice order).
void append_part(SweepResult& result, const BatchPart& part);

}  // namespace bsdfmix
