// Shared by the EM engine, its CPU reference and the benchmark: slice preparation,
// initialization, and the reference iteration.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <utility>
#include <string>
#include <vector>

#include "device/routine.hpp"
#include "device/shapes.hpp"
#include "fit/em.hpp"

namespace bsdfmix::em_detail {

// A slice ready to fit: weights normalized to sum 1 (empty when the slice is zero).
struct PreparedSlice {
  std::vector<double> w;
  std::size_t positive = 0;  // cells with w > 0
  std::string failure;       // non-empty: the slice cannot be fitted at all
};

PreparedSlice prepare_slice(const SliceSet& set, std::size_t slice);

// Why a task cannot run on this slice ("" when it can).
std::string task_failure(const PreparedSlice& s, std::size_t slice, int k);

// Checks tasks against the set (slice index, 1 <= k <= kEmMaxK, settings). Throws ConfigError.
void validate_tasks(const SliceSet& set, const std::vector<EmTask>& tasks);

// The covariance floor in effect (rad^2).
double cov_floor(const SliceGrid& grid, const EmSettings& s);

// Raises the eigenvalues of the covariance (s_tt, s_tp, s_pp) to at least `floor`,
// keeping its eigenvectors (kernels/em.cl floor_covariance does the same).
void floor_covariance(double& stt, double& stp, double& spp, double floor);

// Deterministic initialization from (seed, slice, k, restart): weighted k-means++
// seeding (phi distances to the nearest image), then one hard-assignment pass
// giving weights, means and covariances (+ floor) of the k clusters.
Gmm initialize(const SliceGrid& grid, const std::vector<double>& w, std::size_t slice, int k,
               int restart, const EmSettings& settings);

// The start of restart `restart` of a task: its explicit `init` for restart 0 when it
// has one, else initialize().
Gmm task_start(const SliceGrid& grid, const std::vector<double>& w, const EmTask& task, int restart);

// The reference EM from `init` (double precision); loglik of the final state with
// the exact periodic density. `iterate_seconds` receives the time of the iterations.
EmResult run_reference(const SliceGrid& grid, const std::vector<double>& w, const Gmm& init,
                       const EmSettings& settings, double* iterate_seconds = nullptr);

// sum_i w_i log gmm_density(x_i) over the grid.
double weighted_loglik(const SliceGrid& grid, const std::vector<double>& w, const Gmm& gmm);

// Smallest power of two >= max(k, 4): the K_MAX a problem of k components runs under.
int k_bucket(int k);

// Problems grouped by their k_bucket (bucket -> problem indices), cut into batches of at
// most batch_budget / (stride * (bucket + extra_rows)) problems: (bucket, indices) each.
std::vector<std::pair<int, std::vector<std::size_t>>> bucket_batches(
    const std::map<int, std::vector<std::size_t>>& groups, std::size_t stride, int extra_rows,
    std::uint64_t batch_budget);

// The six E-step constants of component j of `gmm` (kernels/em.cl component_constants) into
// rows 0..5 of `cp` (row stride K), computed in double then rounded to float: the mean, the
// inverse covariance times -log2(e) / 2, and log2_weight - log2(2 pi) - log2(det) / 2.
void component_constants(const Gmm& gmm, int j, int K, double log2_weight, float* cp);

// The build options of the fitting programs (kernels/em.cl, l1.cl, amplitudes.cl) for a
// K_MAX bucket, a kernel shape and a precision.
std::string em_program_options(int k_max, const KernelShape& shape, bool fp64, Map map);

// The cells of a slice grid in chunks of kChunkCells, as the kernels walk them: a slice
// takes `stride` floats (its cells, then zero padding to whole chunks).
struct ChunkLayout {
  std::size_t cells = 0, chunks = 0, stride = 0, n_phi = 0;
  double dtheta = 0, dphi = 0;  // dtheta 0 for a single theta row
  Map map = Map::ThetaPhi;      // the grid's plane: the programs' MAP
  explicit ChunkLayout(const SliceGrid& grid);
};

// Sets the grid arguments that em_estep, em_loglik, em_l1 and amp_basis share
// (slice_stride, n_phi, inv_nphi, theta0, dtheta, phi0, dphi).
void set_grid_args(Routine& routine, const ChunkLayout& layout, const SliceGrid& grid);

// A batch of problems of one K bucket: their indices in the call.
struct ProblemBatch {
  int bucket = 0;
  std::vector<std::size_t> items;
};

// Groups of problems, in order, each of one K bucket, cut into batches (bucket_batches)
// after checking that one problem of each fits a device (check_problem_fits).
std::vector<ProblemBatch> plan_batches(const std::vector<std::pair<int, std::vector<std::size_t>>>& groups,
                                       std::size_t stride, int extra_rows, std::uint64_t limit,
                                       std::uint64_t batch_budget);

// One run of a batch, as EmEngine::run_batches hands it to an algorithm's work.
struct BatchWork {
  const ProblemBatch& batch;
  const BatchRun& run;
  const Device& device;
  bool fp64;           // the device's real type (EmEngine::uses_fp64)
  KernelShape shape;   // the device's kernel shape
  std::size_t size() const { return batch.items.size(); }
  int bucket() const { return batch.bucket; }
};

// The slices of a batch's problems as the batch holds them: problem i of the batch reads
// slice local[i] of the batch's upload, slices numbered in the order they first appear.
struct BatchSlices {
  std::vector<int> local;                // per problem of the batch
  std::map<std::size_t, int> of_slice;   // slice of the call -> its number in the batch
  // slice_of(i): the slice (of the call) of problem i of the batch, for i < n.
  BatchSlices(std::size_t n, const std::function<std::size_t(std::size_t)>& slice_of);
  std::size_t count() const { return of_slice.size(); }
};

// Checks what every query of a batched routine holds (`what`: "L1 query"): its slice below
// n_slices, its K within 1..kEmMaxK. ConfigError.
void check_query(const std::string& what, std::size_t slice, std::size_t n_slices, int k);

// Runs a batch's device work: an OpenCL error becomes a DeviceError naming `what` and the
// device. True when this run is the first to finish the batch (BatchRun::claim): only then
// may it write the batch's results.
bool run_on_device(const BatchRun& run, const Device& device, const std::string& what,
                   const std::function<void()>& work);

// A DeviceError when one problem of `bucket` (+ extra_rows) rows of `stride` cells passes
// `limit` point-components (EmEngine::budget's device limit): a slice too large for a
// device's largest single allocation, the only work that cannot be split.
void check_problem_fits(std::size_t stride, int bucket, int extra_rows, std::uint64_t limit);

// Values in the device's real type (double or float), as bytes, and back.
std::vector<unsigned char> pack(const std::vector<double>& v, bool fp64);
double unpack(const std::vector<unsigned char>& b, std::size_t i, bool fp64);

// Largest eigenvalue of the covariance [a b; b c] and its unit eigenvector; with
// `minor`, the smallest and the eigenvector perpendicular.
void principal_axis(double a, double b, double c, double& lambda, double& vx, double& vy, bool minor = false);

}  // namespace bsdfmix::em_detail
