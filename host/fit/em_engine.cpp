// The OpenCL EM engine: batches of problems (task x restart) on work queues over devices.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
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

void set_grid_args(cl::Kernel& kernel, const ChunkLayout& layout, const SliceGrid& grid) {
  kernel.setArg(0, static_cast<cl_uint>(layout.stride));
  kernel.setArg(1, static_cast<cl_uint>(layout.n_phi));
  kernel.setArg(2, static_cast<float>(1.0 / static_cast<double>(layout.n_phi)));
  kernel.setArg(3, static_cast<float>(grid.theta.front()));
  kernel.setArg(4, static_cast<float>(layout.dtheta));
  kernel.setArg(5, static_cast<float>(grid.phi.front()));
  kernel.setArg(6, static_cast<float>(layout.dphi));
}

KernelShape shape_for(const DeviceInfo& info, bool gpu_layout) {
  if (info.is_cpu() && !gpu_layout) return {16, 1, static_cast<int>(kChunkCells / 16)};
  return {1, 64, static_cast<int>(kChunkCells / 64)};
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
    : devices_(std::move(devices)), queues_per_device_(queues_per_device), precision_(precision) {
  if (devices_.empty()) throw DeviceError("EM engine: no device given");
  if (queues_per_device_ < 1)
    throw ConfigError("EM engine: queues per device must be at least 1, not " +
                      std::to_string(queues_per_device_));
  if (precision_ == EmPrecision::Fp64)
    for (const auto& d : devices_)
      if (!d.info().fp64)
        throw DeviceError("EM engine: fp64 requested but " + d.info().label() +
                          " has no cl_khr_fp64 (use fp32 or auto)");
}

void EmEngine::make_queues(std::vector<cl::CommandQueue>& queues, std::vector<std::size_t>& device) const {
  for (std::size_t d = 0; d < devices_.size(); ++d)
    for (int q = 0; q < queues_per_device_; ++q) {
      queues.push_back(devices_[d].make_queue());
      device.push_back(d);
    }
}

bool EmEngine::uses_fp64(std::size_t device) const {
  if (precision_ == EmPrecision::Fp32) return false;
  return devices_.at(device).info().fp64;
}

std::vector<EmResult> EmEngine::fit(const SliceSet& set, const std::vector<EmTask>& tasks,
                                    Progress* progress) {
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
  using Key = std::tuple<int, int, double, double, double>;
  std::map<Key, std::vector<std::size_t>> groups;
  for (std::size_t pi = 0; pi < problems.size(); ++pi) {
    const EmTask& t = tasks[problems[pi].task];
    const EmSettings& s = t.settings;
    groups[Key{k_bucket(t.k), s.iterations, s.tolerance, cov_floor(grid, s), s.min_weight}].push_back(pi);
  }
  std::vector<Batch> batches;
  for (auto& [key, list] : groups) {
    const int bucket = std::get<0>(key);
    const std::uint64_t per = static_cast<std::uint64_t>(stride) * static_cast<std::uint64_t>(bucket);
    const std::size_t cap = static_cast<std::size_t>(std::max<std::uint64_t>(1, batch_budget_ / per));
    for (std::size_t b = 0; b < list.size(); b += cap) {
      Batch batch{bucket, &tasks[problems[list[b]].task].settings, {}};
      batch.problems.assign(list.begin() + b, list.begin() + std::min(list.size(), b + cap));
      batches.push_back(std::move(batch));
    }
  }
  timing_.batches = batches.size();

  // One queue per worker.
  std::vector<cl::CommandQueue> queues;
  std::vector<std::size_t> queue_device;
  make_queues(queues, queue_device);
  std::mutex timing_mutex;

  auto run_batch = [&](std::size_t worker, std::size_t bi) {
    const Batch& batch = batches[bi];
    const std::size_t d = queue_device[worker];
    const Device& dev = devices_[d];
    const cl::CommandQueue& queue = queues[worker];
    const bool fp64 = uses_fp64(d);
    const KernelShape shape = shape_for(dev.info(), gpu_layout_);
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
      const cl::Context& ctx = dev.context();
      cl::Buffer b_weights(ctx, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, weights.size() * 4, weights.data());
      cl::Buffer b_slice(ctx, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, P * sizeof(int), prob_slice.data());
      cl::Buffer b_k(ctx, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, P * sizeof(int), prob_k.data());
      cl::Buffer b_status(ctx, CL_MEM_READ_WRITE | CL_MEM_COPY_HOST_PTR, status.size() * sizeof(int), status.data());
      cl::Buffer b_state(ctx, CL_MEM_READ_WRITE | CL_MEM_COPY_HOST_PTR, state_bytes.size(), state_bytes.data());
      cl::Buffer b_lprev(ctx, CL_MEM_READ_WRITE, P * real_size);
      cl::Buffer b_partials(ctx, CL_MEM_READ_WRITE, P * n_chunks * nstat * real_size);
      cl::Buffer b_const(ctx, CL_MEM_READ_WRITE, P * nstate * sizeof(float));
      cl::Buffer b_ll(ctx, CL_MEM_WRITE_ONLY, ll_bytes.size());

      cl::Kernel k_const(program, "em_constants"), k_estep(program, "em_estep"),
          k_mstep(program, "em_mstep"), k_ll(program, "em_loglik");
      const cl_uint nP = static_cast<cl_uint>(P);
      k_const.setArg(0, nP);
      k_const.setArg(1, b_k);
      k_const.setArg(2, b_state);
      k_const.setArg(3, b_const);
      for (cl::Kernel* kk : {&k_estep, &k_ll}) {
        set_grid_args(*kk, layout, grid);
        kk->setArg(7, b_weights);
        kk->setArg(8, b_slice);
        kk->setArg(9, b_k);
        kk->setArg(10, b_status);
        kk->setArg(11, b_const);
      }
      k_estep.setArg(12, b_partials);
      k_ll.setArg(12, b_ll);
      k_mstep.setArg(0, nP);
      k_mstep.setArg(1, static_cast<cl_uint>(n_chunks));
      k_mstep.setArg(3, static_cast<cl_int>(s.iterations));
      auto set_real = [&](cl::Kernel& kk, cl_uint idx, double v) {
        if (fp64) kk.setArg(idx, v);
        else kk.setArg(idx, static_cast<float>(v));
      };
      set_real(k_mstep, 4, s.tolerance);
      set_real(k_mstep, 5, cov_floor(grid, s));
      set_real(k_mstep, 6, s.min_weight);
      k_mstep.setArg(7, b_k);
      k_mstep.setArg(8, b_status);
      k_mstep.setArg(9, b_state);
      k_mstep.setArg(10, b_lprev);
      k_mstep.setArg(11, b_partials);
      k_mstep.setArg(12, b_const);

      const cl::NDRange e_global(n_chunks * static_cast<std::size_t>(shape.wg), P);
      const cl::NDRange e_local(static_cast<std::size_t>(shape.wg), 1);
      launch(queue, k_const, "em_constants", cl::NDRange(P));
      for (int it = 1; it <= s.iterations; ++it) {
        launch(queue, k_estep, "em_estep", e_global, e_local);
        k_mstep.setArg(2, static_cast<cl_int>(it));
        launch(queue, k_mstep, "em_mstep", cl::NDRange(P));
        ++launched;
        if (it % kStatusEvery == 0 && it < s.iterations) {
          queue.enqueueReadBuffer(b_status, CL_TRUE, 0, status.size() * sizeof(int), status.data());
          bool all = true;
          for (std::size_t i = 0; i < P && all; ++i) all = status[2 * i] != 0;
          if (all) break;
        }
      }
      queue.finish();
      const double iterate_s = seconds_since(t0);
      t0 = std::chrono::steady_clock::now();
      launch(queue, k_ll, "em_loglik", e_global, e_local);
      queue.enqueueReadBuffer(b_status, CL_FALSE, 0, status.size() * sizeof(int), status.data());
      queue.enqueueReadBuffer(b_state, CL_FALSE, 0, state_bytes.size(), state_bytes.data());
      queue.enqueueReadBuffer(b_ll, CL_TRUE, 0, ll_bytes.size(), ll_bytes.data());
      const double finish_s = seconds_since(t0);
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

  run_on_workers(batches.size(), queues.size(), run_batch);

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
