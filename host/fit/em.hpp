// Weighted EM fits of 2D Gaussian mixtures to slices: the OpenCL engine and its CPU reference.
// docs/em.md gives the equations, the periodic-phi method and the tolerances.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "device/batch_pool.hpp"
#include "device/device.hpp"
#include "device/shapes.hpp"
#include "fit/amplitudes.hpp"
#include "fit/gmm.hpp"
#include "fit/l1_refine.hpp"
#include "fit/slices.hpp"

namespace bsdfmix {

namespace em_detail {
struct ProblemBatch;
struct BatchWork;
}  // namespace em_detail

class Progress;

struct EmSettings {
  int iterations = 100;      // at most this many EM iterations (M-steps) per restart
  double tolerance = 1e-6;   // stop when |L_t - L_(t-1)| <= tolerance * max(1, |L_t|); <= 0: never
  int restarts = 3;          // initializations per task; the best final log-likelihood is kept
  std::uint64_t seed = 1;    // initializations depend on (seed, slice, k, restart) only
  double cov_floor = -1;     // rad^2 added to both variances every M-step; < 0: (min cell step / 4)^2
  double min_weight = 1e-6;  // a component with less responsibility mass is re-seeded
};

// One (slice, K) problem.
struct EmTask {
  std::size_t slice = 0;
  int k = 1;
  EmSettings settings;
  // An explicit start: when non-empty (k components), restart 0 starts from it
  // instead of the k-means++ initialization; restarts r >= 1 are initialized as usual.
  Gmm init = {};
};

struct EmResult {
  Gmm gmm;
  double loglik = 0;  // sum_i w_i log p(x_i), w normalized to sum 1, p = gmm_density
  int iterations = 0;  // EM iterations of the kept restart
  bool ok = false;
  std::string failure;  // why, when !ok
};

// The largest K a task may ask for.
constexpr int kEmMaxK = 128;

// The CPU reference: the same initialization and EM in double precision (Eigen),
// one task after the other. Throws InputError/ConfigError on invalid input.
std::vector<EmResult> em_fit_reference(const SliceSet& set, const std::vector<EmTask>& tasks);

enum class EmPrecision { Auto, Fp32, Fp64 };  // Auto: fp64 where the device has it

// How an engine runs; the command line fills it from the environment (BSDFMIX_PRECISION,
// BSDFMIX_POOL_LOG; host/cli/environment.hpp).
struct EngineOptions {
  EmPrecision precision = EmPrecision::Auto;
  bool pool_log = false;  // print every batch run of the work queues (device/batch_pool.hpp)
};

// Seconds spent by the last fit(): wall time, and per phase summed over batches.
struct EmTiming {
  double seconds = 0, init_seconds = 0, iterate_seconds = 0, finish_seconds = 0;
  std::size_t batches = 0;
  long long iterations = 0;  // EM iterations launched, summed over batches
  std::size_t repeated = 0;  // batches run again on a faster device (device/batch_pool.hpp)
};

// The OpenCL engine: batches of problems (task x restart) handed to work queues,
// queues_per_device on each device, one host thread per queue (device/batch_pool.hpp:
// devices of different speeds each take the work they finish soonest).
class EmEngine {
 public:
  explicit EmEngine(std::vector<Device> devices, int queues_per_device = 1,
                    EmPrecision precision = EmPrecision::Auto);
  EmEngine(std::vector<Device> devices, int queues_per_device, const EngineOptions& options);

  std::vector<EmResult> fit(const SliceSet& set, const std::vector<EmTask>& tasks,
                            Progress* progress = nullptr);

  // The L1 refinement's objective and gradient statistics of each query (kernels/em.cl
  // em_l1, fit/l1_refine.hpp): queries batched by K bucket over the work queues like fit().
  // A refinement evaluates the same slices many times: l1_prepare checks and normalizes
  // them once (throws InputError), and the first overload takes them made ready.
  struct L1Slices {
    SliceGrid grid;
    std::vector<std::vector<float>> w;  // per slice, normalized to sum 1; empty: a zero slice
    // With the set's rgb: per slice, its l1_channels as 3 rows of the padded stride (zero
    // for a slice without them); empty: no colour.
    std::vector<std::vector<float>> rgb;
  };
  static L1Slices l1_prepare(const SliceSet& set);
  std::vector<L1Value> l1_values(const L1Slices& slices, const std::vector<L1Query>& queries,
                                 const L1Objective& objective);
  std::vector<L1Value> l1_values(const SliceSet& set, const std::vector<L1Query>& queries,
                                 const L1Objective& objective) {
    return l1_values(l1_prepare(set), queries, objective);
  }

  // The normal-equation sums of the amplitude fit (fit/amplitudes.hpp; kernels/em.cl
  // amp_basis and amp_sums) of each query, batched by K bucket over the work queues. The
  // channels are checked and made ready once (amp_prepare), evaluated many times.
  struct AmpSlices {
    SliceGrid grid;
    int channels = 1;
    std::vector<std::vector<float>> w;  // per slice, kMaxChannels rows of the padded stride
  };
  static AmpSlices amp_prepare(const ChannelSet& set);
  std::vector<AmplitudeSums> amplitude_sums(const AmpSlices& slices, const std::vector<AmplitudeQuery>& queries);

  // Upper bound on the point-component updates of one EM iteration of a batch
  // (sum over its problems of padded cells x K bucket); at least one problem per batch.
  void set_batch_budget(std::uint64_t point_components) { batch_budget_ = point_components; }
  std::size_t queue_count() const { return pool_->queue_count(); }
  const std::vector<Device>& devices() const { return devices_; }
  bool uses_fp64(std::size_t device) const;
  // The kernel shape of the fitting routines on device d (device/shapes.hpp choose_shape,
  // once per engine: a tuned entry is read from its file when the engine is made).
  KernelShape shape(std::size_t d) const { return shapes_.at(d); }
  const EmTiming& last_timing() const { return timing_; }
  // Runs the layout meant for GPUs (one cell per work-item, 64 work-items per
  // work-group, local-memory reductions) on every device, CPUs included.
  void set_gpu_layout(bool on);
  // Runs `shape` on every device instead of its table or tuned entry (`bsdfmix tune`).
  void set_shape(const KernelShape& shape) { shapes_.assign(devices_.size(), shape); }

 private:
  // The batch budget in effect: batch_budget_, lowered so that no buffer of a batch passes
  // any device's largest single allocation and a batch's buffers stay within a sixteenth
  // of its global memory (4 bytes per point-component at most in one buffer, 12 in all).
  std::uint64_t budget() const;
  std::uint64_t device_limit() const;
  // With several devices, once: a small EM fit timed on each device alone. A device more
  // than kSlowDevice times slower than the fastest is given that rate, so that it never
  // starts a real batch it would hold for long (a launch cannot be stopped once running);
  // devices within that factor are measured on real batches.
  void calibrate();
  bool calibrated_ = false;
  // The batch skeleton of fit, l1_values and amplitude_sums: every batch of `batches`
  // (em_detail::plan_batches; cost[b], its work) run over the pool as `routine`, `work`
  // called once per run of a batch with its device, precision and kernel shape.
  void run_batches(const std::string& routine, const std::vector<em_detail::ProblemBatch>& batches,
                   const std::vector<double>& cost, const std::function<void(const em_detail::BatchWork&)>& work);

  std::vector<Device> devices_;
  std::shared_ptr<BatchPool> pool_;
  EmPrecision precision_;
  bool pool_log_;
  std::uint64_t batch_budget_ = std::uint64_t(1) << 25;
  std::vector<KernelShape> shapes_;  // per device
  EmTiming timing_;
};

std::string precision_name(EmPrecision p);  // auto, fp32, fp64
EmPrecision parse_precision(const std::string& name);  // throws ConfigError

}  // namespace bsdfmix
