// The fitting sweep of `bsdfmix fit`: for every slice it needs, search the Gaussian
// count, fit the chosen K thoroughly, and write the mixture file, the fit report and
// the search CSVs. Batches of slices are committed as they finish (sweep/checkpoint.hpp).
// The same fits without files: fit_slices (sweep/fit_slices.hpp).
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "sweep/fit_settings.hpp"
#include "fit/em.hpp"
#include "sweep/checkpoint.hpp"
#include "sweep/fit_phases.hpp"
#include "sweep/slice_plan.hpp"

namespace bsdfmix {

struct SweepSummary {
  bool complete = true;  // false: stopped at max_batches, outputs not written yet
  std::size_t slices = 0, resumed = 0, failed = 0;
  std::map<int, std::size_t> k_histogram;
  double l1_median = 0, l1_p90 = 0, l1_max = 0;
  // Sizes, in the bytes a user ships: files on disk and their dataset payloads.
  std::uint64_t mixture_file_bytes = 0;  // the mixture file on disk
  std::uint64_t mixture_bytes = 0;       // its datasets as stored ([S, Kmax] padded arrays included)
  std::uint64_t table_file_bytes = 0;    // the table file on disk
  std::uint64_t table_bytes = 0;         // the fitted slices' cells in the table (float32)
  std::size_t table_slices = 0;          // slices the table holds (the plan may fit fewer)
  std::uint64_t full_bytes = 0;          // the fitted slices' cells without azimuthal symmetry (float32)
  std::size_t symmetry_factor = 1;       // phi_o slices one stored slice stands for
  double seconds = 0;
  double cpu_seconds = 0;  // this process's CPU time over the run (MPI workers' not counted)
  unsigned cores = 1;      // the machine's logical CPUs
  FitPhases phases;        // where the time of the batches fitted in this process went
  std::string map;         // fit.map auto: the probe's choice (MapChoice::text); "" otherwise
  std::string devices;
  // Warnings on the result (sweep_warnings), printed after the summary on stderr.
  std::vector<std::string> warnings;
  std::string text() const;          // the printed summary
  double cpu_utilization() const;    // cpu_seconds over seconds x cores: 1 keeps every core busy
};

// The fit settings that make a result, as JSON (the mixture file's `fit_settings`
// attribute, docs/formats.md): every key of the `fit:` section but the paths and slices.
std::string fit_settings_json(const FitSettings& fit);

// How run_sweep fits its batches. Without a farm, one after the other in this process.
// A farm (the MPI task farm, scale/mpi_farm.hpp) fits them wherever it likes: it calls
// `commit` once per batch, in any order, on the calling thread, and may fit a batch here
// with `fit_here`. The fit of a batch depends only on its slices and the settings, so
// where and in which order batches are fitted does not change the result.
class BatchFarm {
 public:
  virtual ~BatchFarm() = default;
  // `map`: the map the batches are fitted in (fit.map with auto chosen).
  virtual void run(const std::vector<std::vector<SliceRef>>& batches, const std::string& map,
                   const std::function<BatchPart(const std::vector<SliceRef>&)>& fit_here,
                   const std::function<void(BatchPart&&)>& commit) = 0;
};

// Batches in flight by default (sweep/batch_lanes.hpp): two keep the cores busy through
// a batch's host steps; more add memory (one batch each) and little speed (three: 0.97x
// two's wall time on a satin fit on 2 cores). One on a device that takes one host
// thread at a time (DeviceInfo::concurrent_host_threads).
constexpr unsigned kDefaultLanes = 2;

// How run_sweep runs, beside the fit settings: where it stops, where its batches are
// fitted, and how its engine runs (the fingerprint records the precision in force).
struct SweepOptions {
  // Stop after committing this many batches (the summary's `complete` is false and no
  // final file is written): a later run resumes from the checkpoint.
  std::size_t max_batches = SIZE_MAX;
  BatchFarm* farm = nullptr;  // not owned; nullptr: every batch fitted here
  EngineOptions engine;       // the EM engine's precision and log
  // Batches fitted side by side here (sweep/batch_lanes.hpp) when there is no farm: the
  // result does not depend on it.
  unsigned lanes = kDefaultLanes;
};

// Fits the slices `fit` asks for.
SweepSummary run_sweep(const std::string& table_path, const FitSettings& fit, const std::string& device_selector,
                       const SweepOptions& options = {});

// The fitting half of a sweep, without checkpoint or outputs: what a remote worker of a
// farm runs. Fits batches of `table_path` exactly as run_sweep does.
class BatchWorker {
 public:
  BatchWorker(const std::string& table_path, const FitSettings& fit, const std::string& device_selector,
              const EngineOptions& engine = {});
  ~BatchWorker();
  // Fits one batch in `map` (fit.map with auto chosen: the farm's task says which).
  BatchPart fit(const std::vector<SliceRef>& batch, const std::string& map);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace bsdfmix
