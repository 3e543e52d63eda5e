// The MPI task farm of `mpirun -n N bsdfmix fit|catalog` (docs/scale.md). Rank 0 plans
// the batches exactly as a 1-process run does, hands them out dynamically (each worker
// holds up to three at a time, so it does not run dry while rank 0 fits), fits
// batches itself while every worker is busy, and is the only rank that commits
// checkpoint parts and writes outputs: crash safety and resume are those of a
// 1-process run, and the files are bit-identical to it. Without mpirun no MPI call is
// made at all.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "fit/em.hpp"
#include "sweep/fit_settings.hpp"
#include "sweep/sweep.hpp"

namespace bsdfmix::scale {

// One fitting job a worker may be handed batches of: a table and its fit settings.
// Every rank builds the same list from the same config, in the same order.
struct FarmJob {
  std::string table;
  FitSettings fit;
  bool table_ready = false;  // the table exists and rank 0 will not remake it: a worker may open it at once
};

// Batch traffic of the farm, summed over the run_sweep calls of one command.
struct FarmStats {
  std::size_t batches = 0, local_batches = 0;  // fitted in all, by rank 0 itself
  std::uint64_t task_bytes = 0, part_bytes = 0;  // rank 0 -> workers, workers -> rank 0
  double compute_seconds = 0;                    // summed fitting time of the batches, where fitted
  double commit_seconds = 0;                     // rank 0's time committing parts (decode and checkpoint write)
};

// How the farm runs; the command line fills it from the environment
// (host/cli/environment.hpp).
struct FarmOptions {
  // A launcher started this process (mpirun/mpiexec of Open MPI, or any PMI or PMIx
  // launcher: OMPI_COMM_WORLD_SIZE, PMIX_RANK or PMI_SIZE set); else no MPI call is made.
  bool launched = false;
  bool root_fits = true;   // rank 0 fits batches while every worker is busy (BSDFMIX_MPI_ROOT_FITS=0: never)
  std::string stats_path;  // "" or a CSV file each run_sweep appends its traffic to (BSDFMIX_MPI_STATS)
};

// MPI for the length of one command. Launched, with more than one rank, rank 0
// hands batch_farm() to run_sweep (sweep/sweep.hpp SweepOptions) and every other rank
// calls serve(). The destructor tells the workers to stop, waits for them, and ends MPI
// (also when an error is on its way out of rank 0).
class MpiFarm {
 public:
  explicit MpiFarm(const FarmOptions& options = {});
  ~MpiFarm();
  MpiFarm(const MpiFarm&) = delete;
  MpiFarm& operator=(const MpiFarm&) = delete;

  bool active() const { return size_ > 1; }
  bool worker() const { return active() && rank_ != 0; }
  int rank() const { return rank_; }
  int size() const { return size_; }

  // Rank 0 of more than one rank: the farm run_sweep fits its batches with; else nullptr.
  BatchFarm* batch_farm() const;
  // Rank 0: the batches of the next run_sweep belong to jobs[job].
  void set_job(std::size_t job);
  // Rank 0: the traffic so far.
  const FarmStats& stats() const;

  // Ranks > 0: fits the batches rank 0 hands out until it says stop. Throws what a fit
  // threw, after reporting it to rank 0.
  void serve(const std::vector<FarmJob>& jobs, const std::string& device_selector, const EngineOptions& engine = {});

 private:
  struct Root;
  bool initialized_ = false;
  int rank_ = 0, size_ = 1;
  bool stopped_ = false;
  std::unique_ptr<Root> root_;
};

}  // namespace bsdfmix::scale
