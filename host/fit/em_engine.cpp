// The OpenCL EM engine: batches of problems (task x restart) on work queues over devices.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <thread>
#include <tuple>

#include "core/error.hpp"
#include "core/progress.hpp"
#include "device/program.hpp"
#include "fit/em_internal.hpp"
#include "fit/scheduler.hpp"
#include "fit/synthetic.hpp"

namespace bsdfmix {

using namespace em_detail;

namespace em_detail {

ChunkLayout::ChunkLayout(const SliceGrid& grid)
    : cells(grid.cells()),
      chunks((cells + kChunkCells - 1) / kChunkCells),
      stride(chunks * kChunkCells),
      n_phi(grid.phi.size()),
      dtheta(grid.theta.size() > 1 ? axis_step(grid.theta) : 0.0),
      dphi(axis_step(grid.phi)) {}

void set_grid_args(Routine& routine, const ChunkLayout& layout, const SliceGrid& grid) {
  routine.set("slice_stride", static_cast<cl_uint>(layout.stride))
      .set("n_phi", static_cast<cl_uint>(layout.n_phi))
      .set("inv_nphi", static_cast<float>(1.0 / static_cast<double>(layout.n_phi)))
      .set("theta0", static_cast<float>(grid.theta.front()))
      .set("dtheta", static_cast<float>(layout.dtheta))
      .set("phi0", static_cast<float>(grid.phi.front()))
      .set("dphi", static_cast<float>(layout.dphi));
}

std::string em_program_options(int k_max, const KernelShape& shape, bool fp64) {
  return "-DK_MAX=" + std::to_string(k_max) + " -DVEC=" + std::to_string(shape.vec) + " -DWG=" +
         std::to_string(shape.wg) + " -DCPW=" + std::to_string(shape.cpw) + " -DEM_FP64=" + (fp64 ? "1" : "0") +
         " -cl-denorms-are-zero";
}

std::vector<unsigned char> pack(const std::vector<double>& v, bool fp64) {
  std::vector<unsigned char> out(v.size() * (fp64 ? 8 : 4));
  if (fp64) {
    std::memcpy(out.data(), v.data(), out.size());
  } else {
    for (std::size_t i = 0; i < v.size(); ++i) {
      const float f = static_cast<float>(v[i]);
      std::memcpy(out.data() + 4 * i, &f, 4);
    }
  }
  return out;
}

double unpack(const std::vector<unsigned char>& b, std::size_t i, bool fp64) {
  if (fp64) {
    double d;
    std::memcpy(&d, b.data() + 8 * i, 8);
    return d;
  }
  float f;
  std::memcpy(&f, b.data() + 4 * i, 4);
  return f;
}

}  // namespace em_detail

namespace {

// Iterations between two reads of the per-problem status (to stop converged batches).
constexpr int kStatusEvery = 4;

struct Problem {
  std::size_t task;
  int restart;
};

struct Batch {
  int bucket;
  const EmSettings* settings;
  std::vector<std::size_t> problems;
};

double seconds_since(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

}  // namespace

EmEngine::EmEngine(std::vector<Device> devices, int queues_per_device, EmPrecision precision)
    : EmEngine(std::move(devices), queues_per_device, EngineOptions{precision, false}) {}

EmEngine::EmEngine(std::vector<Device> devices, int queues_per_device, const EngineOptions& options)
    : devices_(std::move(devices)), precision_(options.precision), pool_log_(options.pool_log) {
  if (devices_.empty()) throw DeviceError("EM engine: no device given");
  if (queues_per_device < 1)
    throw ConfigError("EM engine: queues per device must be at least 1, not " + std::to_string(queues_per_device));
  pool_ = std::make_shared<BatchPool>(devices_, queues_per_device, pool_log_);
  set_gpu_layout(false);
  if (precision_ == EmPrecision::Fp64)
    for (const auto& d : devices_)
      if (!d.info().fp64)
        throw DeviceError("EM engine: fp64 requested but " + d.info().label() +
                          " has no cl_khr_fp64 (use fp32 or auto)");
}

std::uint64_t EmEngine::budget() const { return std::min(batch_budget_, device_limit()); }

std::uint64_t EmEngine::device_limit() const {
  std::uint64_t limit = std::numeric_limits<std::uint64_t>::max();
  for (const auto& d : devices_) {
    if (d.info().max_alloc) limit = std::min<std::uint64_t>(limit, d.info().max_alloc / 4);
    if (d.info().global_mem) limit = std::min<std::uint64_t>(limit, d.info().global_mem / 16);
  }
  return limit;
}

void EmEngine::set_gpu_layout(bool on) {
  shapes_.clear();
  for (const auto& d : devices_) shapes_.push_back(choose_shape(d.info(), on).shape);
}

bool EmEngine::uses_fp64(std::size_t device) const {
  if (precision_ == EmPrecision::Fp32) return false;
  return devices_.at(device).info().fp64;
}

namespace {
// A device this many times slower than the fastest at the calibration fit is kept to that
// rate until it measures itself otherwise.
constexpr double kSlowDevice = 10;
}  // namespace

void EmEngine::calibrate() {
  calibrated_ = true;
  if (devices_.size() < 2) return;
  SliceSet set;
  set.grid = make_slice_grid(Domain::Fiber, 16, 32);  // 512 cells: one chunk
  set.weights.push_back(mixture_weights(set.grid, synthetic_lobes(Domain::Fiber, 4, 7)));
  EmTask task;
  task.k = 4;
  task.settings.iterations = 2;
  task.settings.tolerance = 0;
  task.settings.restarts = 1;
  const double cost = static_cast<double>(ChunkLayout(set.grid).stride) * k_bucket(task.k) * task.settings.iterations;
  std::vector<double> rate(devices_.size());
  for (std::size_t d = 0; d < devices_.size(); ++d) {
    EmEngine one({devices_[d]}, 1, EngineOptions{precision_, pool_log_});
    one.set_shape(shapes_[d]);
    one.fit(set, {task});  // builds the program (kept by the device for the real work)
    const auto t0 = std::chrono::steady_clock::now();
    one.fit(set, {task});
    rate[d] = seconds_since(t0) / cost;
  }
  // Where one device is that much slower, every device starts with its rate (the slow one's
  // ratio to the others is what keeps it from real batches); else all are measured on them.
  const double fastest = *std::min_element(rate.begin(), rate.end());
  if (*std::max_element(rate.begin(), rate.end()) > kSlowDevice * fastest)
    for (std::size_t d = 0; d < devices_.size(); ++d) pool_->seed_rate("em", d, rate[d]);
}

std::vector<EmResult> EmEngine::fit(const SliceSet& set, const std::vector<EmTask>& tasks,
                                    Progress* progress) {
  if (!calibrated_) calibrate();
  const auto fit_start = std::chrono::steady_clock::now();
  timing_ = EmTiming{};
  validate_slices(set);
  validate_tasks(set, tasks);
  const SliceGrid& grid = set.grid;
  const ChunkLayout layout(grid);
  const std::size_t n_cells = layout.cells, n_chunks = layout.chunks, stride = layout.stride;

  // Slices, task failures, problems.
  std::vector<std::unique_ptr<PreparedSlice>> prepared(set.weights.size());
  std::vector<EmResult> out(tasks.size());
  std::vector<Problem> problems;
  std::vector<std::atomic<int>> remaining(tasks.size());
  for (std::size_t ti = 0; ti < tasks.size(); ++ti) {
    const EmTask& t = tasks[ti];
    if (!prepared[t.slice]) prepared[t.slice] = std::make_unique<PreparedSlice>(prepare_slice(set, t.slice));
    out[ti].ok = false;
    out[ti].loglik = -std::numeric_limits<double>::infinity();
    if (std::string why = task_failure(*prepared[t.slice], t.slice, t.k); !why.empty()) {
      out[ti].failure = why;
      remaining[ti] = 0;
      if (progress) progress->advance(1);
      continue;
    }
    remaining[ti] = t.settings.restarts;
    for (int r = 0; r < t.settings.restarts; ++r) problems.push_back({ti, r});
  }
  std::vector<EmResult> results(problems.size());

  // Batches: problems of one K bucket and one set of settings, up to the budget.
  struct Key {  // what a batch's problems share
    int bucket, iterations;
    double tolerance, cov_floor, min_weight;
    bool operator<(const Key& o) const {
      return std::tie(bucket, iterations, tolerance, cov_floor, min_weight) <
             std::tie(o.bucket, o.iterations, o.tolerance, o.cov_floor, o.min_weight);
    }
  };
  std::map<Key, std::vector<std::size_t>> groups;
  for (std::size_t pi = 0; pi < problems.size(); ++pi) {
    const EmTask& t = tasks[problems[pi].task];
    const EmSettings& s = t.settings;
    groups[Key{k_bucket(t.k), s.iterations, s.tolerance, cov_floor(grid, s), s.min_weight}].push_back(pi);
  }
  std::vector<Batch> batches;
  std::vector<double> cost;
  const std::uint64_t limit = device_limit();
  for (auto& [key, list] : groups) {
    const int bucket = key.bucket;
    check_problem_fits(stride, bucket, 0, limit);
    for (auto& [b, items] : bucket_batches({{bucket, list}}, stride, 0, budget())) {
      const EmSettings& s = tasks[problems[items.front()].task].settings;
      cost.push_back(static_cast<double>(items.size()) * static_cast<double>(stride) * b * s.iterations);
      batches.push_back(Batch{b, &s, std::move(items)});
    }
  }
  timing_.batches = batches.size();

  std::mutex timing_mutex;

  auto run_batch = [&](const BatchRun& run) {
    const Batch& batch = batches[run.batch];
    const std::size_t d = run.device;
    const Device& dev = devices_[d];
    const cl::CommandQueue& queue = *run.queue;
    const bool fp64 = uses_fp64(d);
    const KernelShape shape = this->shape(d);
    const int K = batch.bucket;
    const EmSettings& s = *batch.settings;
    const std::size_t P = batch.problems.size();
    const std::size_t real_size = fp64 ? 8 : 4;
    const std::size_t nstat = 6 * static_cast<std::size_t>(K) + 1, nstate = 6 * static_cast<std::size_t>(K);

    auto t0 = std::chrono::steady_clock::now();
    // Initial states and the slices of the batch.
    std::map<std::size_t, int> local_slice;
    std::vector<int> prob_slice(P), prob_k(P);
    std::vector<double> state(P * nstate, 0.0);
    for (std::size_t i = 0; i < P; ++i) {
      const EmTask& t = tasks[problems[batch.problems[i]].task];
      auto it = local_slice.find(t.slice);
      if (it == local_slice.end()) it = local_slice.emplace(t.slice, static_cast<int>(local_slice.size())).first;
      prob_slice[i] = it->second;
      prob_k[i] = t.k;
    }
    // Initializations in parallel on the host (each depends on its problem only).
    const std::size_t init_threads =
        std::min<std::size_t>(P, std::max(1u, std::thread::hardware_concurrency()));
    run_on_workers(P, init_threads, [&](std::size_t, std::size_t i) {
      const Problem& pr = problems[batch.problems[i]];
      const EmTask& t = tasks[pr.task];
      const Gmm g = task_start(grid, prepared[t.slice]->w, t, pr.restart);
      double* st = &state[i * nstate];
      for (int j = 0; j < t.k; ++j) {
        st[0 * K + j] = g.weight[j];
        st[1 * K + j] = g.mean[2 * j];
        st[2 * K + j] = g.mean[2 * j + 1];
        st[3 * K + j] = g.cov[3 * j];
        st[4 * K + j] = g.cov[3 * j + 1];
        st[5 * K + j] = g.cov[3 * j + 2];
      }
    });
    std::vector<float> weights(local_slice.size() * stride, 0.0f);
    for (const auto& [slice, local] : local_slice) {
      const auto& w = prepared[slice]->w;
      float* dst = &weights[static_cast<std::size_t>(local) * stride];
      for (std::size_t c = 0; c < n_cells; ++c) dst[c] = static_cast<float>(w[c]);
    }
    const double init_s = seconds_since(t0);

    t0 = std::chrono::steady_clock::now();
    std::vector<int> status(2 * P, 0);
    std::vector<unsigned char> state_bytes = pack(state, fp64);
    std::vector<unsigned char> ll_bytes(P * n_chunks * real_size);
    int launched = 0;
    try {
      cl::Program program = build_program(dev, "em", em_program_options(K, shape, fp64));
      cl::Buffer b_weights = upload(dev, "weights", weights), b_slice = upload(dev, "prob_slice", prob_slice),
                 b_k = upload(dev, "prob_k", prob_k);
      cl::Buffer b_status = device_buffer(dev, "status", status.size() * sizeof(int),
                                          CL_MEM_READ_WRITE | CL_MEM_COPY_HOST_PTR, status.data());
      cl::Buffer b_state = device_buffer(dev, "state", state_bytes.size(), CL_MEM_READ_WRITE | CL_MEM_COPY_HOST_PTR,
                                         state_bytes.data());
      cl::Buffer b_lprev = device_buffer(dev, "lprev", P * real_size, CL_MEM_READ_WRITE);
      cl::Buffer b_partials = device_buffer(dev, "partials", P * n_chunks * nstat * real_size, CL_MEM_READ_WRITE);
      cl::Buffer b_const = device_buffer(dev, "cparams", P * nstate * sizeof(float), CL_MEM_READ_WRITE);
      cl::Buffer b_ll = device_buffer(dev, "loglik partials", ll_bytes.size(), CL_MEM_WRITE_ONLY);

      Routine k_const(program, "em_constants"), k_estep(program, "em_estep"), k_mstep(program, "em_mstep"),
          k_ll(program, "em_loglik");
      const cl_uint nP = static_cast<cl_uint>(P);
      k_const.set("n_problems", nP).set("prob_k", b_k).set("state", b_state).set("cparams", b_const);
      for (Routine* kk : {&k_estep, &k_ll}) {
        set_grid_args(*kk, layout, grid);
        kk->set("weights", b_weights).set("prob_slice", b_slice).set("prob_k", b_k).set("status", b_status)
            .set("cparams", b_const);
      }
      k_estep.set("partials", b_partials);
      k_ll.set("partials", b_ll);
      k_mstep.set("n_problems", nP).set("G", static_cast<cl_uint>(n_chunks)).set("max_iter", static_cast<cl_int>(s.iterations));
      k_mstep.set_real("tol", s.tolerance, fp64).set_real("cov_floor", cov_floor(grid, s), fp64)
          .set_real("min_weight", s.min_weight, fp64);
      k_mstep.set("prob_k", b_k).set("status", b_status).set("state", b_state).set("lprev", b_lprev)
          .set("partials", b_partials).set("cparams", b_const);

      const cl::NDRange e_global(n_chunks * static_cast<std::size_t>(shape.wg), P);
      const cl::NDRange e_local(static_cast<std::size_t>(shape.wg), 1);
      k_const.run(queue, cl::NDRange(P));
      for (int it = 1; it <= s.iterations; ++it) {
        if (run.cancelled()) break;  // another device finished this batch
        k_estep.run(queue, e_global, e_local);
        k_mstep.set("iter", static_cast<cl_int>(it));
        k_mstep.run(queue, cl::NDRange(P));
        ++launched;
        // A run likely to lose to a faster device reads every iteration: if another device
        // finishes the batch first, it stops after one iteration, not kStatusEvery.
        if ((run.watched() || it % kStatusEvery == 0) && it < s.iterations) {
          queue.enqueueReadBuffer(b_status, CL_TRUE, 0, status.size() * sizeof(int), status.data());
          bool all = true;
          for (std::size_t i = 0; i < P && all; ++i) all = status[2 * i] != 0;
          if (all) break;
        }
      }
      if (run.cancelled()) {
        queue.finish();
        return;
      }
      queue.finish();
      const double iterate_s = seconds_since(t0);
      t0 = std::chrono::steady_clock::now();
      k_ll.run(queue, e_global, e_local);
      queue.enqueueReadBuffer(b_status, CL_FALSE, 0, status.size() * sizeof(int), status.data());
      queue.enqueueReadBuffer(b_state, CL_FALSE, 0, state_bytes.size(), state_bytes.data());
      queue.enqueueReadBuffer(b_ll, CL_TRUE, 0, ll_bytes.size(), ll_bytes.data());
      const double finish_s = seconds_since(t0);
      if (!run.claim()) return;  // another device finished this batch first
      std::lock_guard<std::mutex> lock(timing_mutex);
      timing_.init_seconds += init_s;
      timing_.iterate_seconds += iterate_s;
      timing_.finish_seconds += finish_s;
      timing_.iterations += launched;
    } catch (const cl::Error& e) {
      throw_device_error(e, "EM batch on " + dev.info().label());
    }

    for (std::size_t i = 0; i < P; ++i) {
      const std::size_t pi = batch.problems[i];
      const EmTask& t = tasks[problems[pi].task];
      EmResult& r = results[pi];
      r.iterations = status[2 * i + 1];
      Gmm& g = r.gmm;
      g.weight.resize(t.k);
      g.mean.resize(2 * t.k);
      g.cov.resize(3 * t.k);
      for (int j = 0; j < t.k; ++j) {
        const std::size_t b = i * nstate;
        g.weight[j] = unpack(state_bytes, b + 0 * K + j, fp64);
        g.mean[2 * j] = unpack(state_bytes, b + 1 * K + j, fp64);
        g.mean[2 * j + 1] = unpack(state_bytes, b + 2 * K + j, fp64);
        g.cov[3 * j] = unpack(state_bytes, b + 3 * K + j, fp64);
        g.cov[3 * j + 1] = unpack(state_bytes, b + 4 * K + j, fp64);
        g.cov[3 * j + 2] = unpack(state_bytes, b + 5 * K + j, fp64);
      }
      if (status[2 * i] == 2) {
        r.ok = false;
        r.loglik = -std::numeric_limits<double>::infinity();
        r.failure = "numerical failure (non-finite log-likelihood or no responsibility mass) after " +
                    std::to_string(r.iterations) + " iterations";
      } else {
        double l = 0;
        for (std::size_t c = 0; c < n_chunks; ++c) l += unpack(ll_bytes, i * n_chunks + c, fp64);
        r.loglik = l;
        r.ok = std::isfinite(l);
        if (!r.ok) r.failure = "non-finite final log-likelihood";
      }
      if (--remaining[problems[pi].task] == 0 && progress) progress->advance(1);
    }
  };

  pool_->run("em", cost, run_batch);
  timing_.repeated = pool_->repeated();

  // Best restart per task (the first of equal log-likelihoods).
  std::vector<std::string> first_failure(tasks.size());
  for (std::size_t pi = 0; pi < problems.size(); ++pi) {
    const std::size_t ti = problems[pi].task;
    EmResult& r = results[pi];
    if (!r.ok) {
      if (first_failure[ti].empty()) first_failure[ti] = r.failure;
      continue;
    }
    if (!out[ti].ok || r.loglik > out[ti].loglik) out[ti] = std::move(r);
  }
  for (std::size_t ti = 0; ti < tasks.size(); ++ti)
    if (!out[ti].ok && out[ti].failure.empty()) out[ti].failure = "every restart failed: " + first_failure[ti];
  timing_.seconds = seconds_since(fit_start);
  return out;
}

}  // namespace bsdfmix
