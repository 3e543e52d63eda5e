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
      dphi(axis_step(grid.phi)),
      map(grid.map) {}

void set_grid_args(Routine& routine, const ChunkLayout& layout, const SliceGrid& grid) {
  routine.set("slice_stride", static_cast<cl_uint>(layout.stride))
      .set("n_phi", static_cast<cl_uint>(layout.n_phi))
      .set("inv_nphi", static_cast<float>(1.0 / static_cast<double>(layout.n_phi)))
      .set("theta0", static_cast<float>(grid.theta.front()))
      .set("dtheta", static_cast<float>(layout.dtheta))
      .set("phi0", static_cast<float>(grid.phi.front()))
      .set("dphi", static_cast<float>(layout.dphi));
}

std::string em_program_options(int k_max, const KernelShape& shape, bool fp64, Map map) {
  return "-DK_MAX=" + std::to_string(k_max) + " -DVEC=" + std::to_string(shape.vec) + " -DWG=" +
         std::to_string(shape.wg) + " -DCPW=" + std::to_string(shape.cpw) + " -DEM_FP64=" + (fp64 ? "1" : "0") +
         " -DMAP=" + std::to_string(static_cast<int>(map)) + " -cl-denorms-are-zero";
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

double seconds_since(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

// What the batches of one EmEngine::fit call share.
struct FitCall {
  const SliceSet& set;
  const std::vector<EmTask>& tasks;
  Progress* progress;
  const ChunkLayout layout;
  std::vector<std::unique_ptr<PreparedSlice>> prepared;  // per slice, those the tasks fit
  std::vector<EmResult> out;                             // per task
  std::vector<Problem> problems;                         // task x restart
  std::vector<std::atomic<int>> remaining;               // per task: restarts not yet stored
  std::vector<EmResult> results;                         // per problem
  std::mutex timing_mutex;

  // Prepares the tasks' slices; a task that cannot run fails at once, the others' restarts
  // become the problems.
  FitCall(const SliceSet& set_, const std::vector<EmTask>& tasks_, Progress* progress_)
      : set(set_), tasks(tasks_), progress(progress_), layout(set_.grid), prepared(set_.weights.size()),
        out(tasks_.size()), remaining(tasks_.size()) {
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
    results.resize(problems.size());
  }

  const EmTask& task_of(const BatchWork& w, std::size_t i) const { return tasks[problems[w.batch.items[i]].task]; }
};

// A batch's initial states (its problems' starts, in parallel on the host) and slices.
struct EmInputs {
  BatchSlices slices;
  std::vector<int> prob_k;
  std::vector<double> state;  // NSTATE per problem (kernels/em.cl)
  std::vector<float> weights;

  EmInputs(const FitCall& f, const BatchWork& w)
      : slices(w.size(), [&](std::size_t i) { return f.task_of(w, i).slice; }), prob_k(w.size()) {
    const std::size_t P = w.size(), K = static_cast<std::size_t>(w.bucket()), nstate = 6 * K;
    for (std::size_t i = 0; i < P; ++i) prob_k[i] = f.task_of(w, i).k;
    state.assign(P * nstate, 0.0);
    // Each initialization depends on its problem only.
    const std::size_t init_threads = std::min<std::size_t>(P, std::max(1u, std::thread::hardware_concurrency()));
    run_on_workers(P, init_threads, [&](std::size_t, std::size_t i) {
      const Problem& pr = f.problems[w.batch.items[i]];
      const EmTask& t = f.tasks[pr.task];
      const Gmm g = task_start(f.set.grid, f.prepared[t.slice]->w, t, pr.restart);
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
    const std::size_t stride = f.layout.stride;
    weights.assign(slices.count() * stride, 0.0f);
    for (const auto& [slice, local] : slices.of_slice) {
      const auto& src = f.prepared[slice]->w;
      float* dst = &weights[static_cast<std::size_t>(local) * stride];
      for (std::size_t c = 0; c < f.layout.cells; ++c) dst[c] = static_cast<float>(src[c]);
    }
  }
};

// What a batch's device run reads back, and its times.
struct EmOutputs {
  std::vector<int> status;                // [2p] 0 running, 1 done, 2 failed; [2p + 1] iterations
  std::vector<unsigned char> state, ll;   // the final states, the log-likelihood partials (real_t)
  int launched = 0;                       // iterations launched
  double iterate_seconds = 0, finish_seconds = 0;
};

// The four EM kernels of a batch, their buffers made and their arguments set.
struct EmRoutines {
  Routine constants, estep, mstep, loglik;
  cl::Buffer status, state, ll;

  EmRoutines(const cl::Program& program, const FitCall& f, const BatchWork& w, const EmInputs& in, EmOutputs& o,
             const EmSettings& s)
      : constants(program, "em_constants"), estep(program, "em_estep"), mstep(program, "em_mstep"),
        loglik(program, "em_loglik") {
    const Device& dev = w.device;
    const std::size_t P = w.size(), K = static_cast<std::size_t>(w.bucket()), real_size = w.fp64 ? 8 : 4;
    const std::size_t nstat = 6 * K + 1, nstate = 6 * K, n_chunks = f.layout.chunks;
    cl::Buffer b_weights = upload(dev, "weights", in.weights), b_slice = upload(dev, "prob_slice", in.slices.local),
               b_k = upload(dev, "prob_k", in.prob_k);
    status = device_buffer(dev, "status", o.status.size() * sizeof(int), CL_MEM_READ_WRITE | CL_MEM_COPY_HOST_PTR,
                           o.status.data());
    state = device_buffer(dev, "state", o.state.size(), CL_MEM_READ_WRITE | CL_MEM_COPY_HOST_PTR, o.state.data());
    cl::Buffer b_lprev = device_buffer(dev, "lprev", P * real_size, CL_MEM_READ_WRITE);
    cl::Buffer b_partials = device_buffer(dev, "partials", P * n_chunks * nstat * real_size, CL_MEM_READ_WRITE);
    cl::Buffer b_const = device_buffer(dev, "cparams", P * nstate * sizeof(float), CL_MEM_READ_WRITE);
    ll = device_buffer(dev, "loglik partials", o.ll.size(), CL_MEM_WRITE_ONLY);

    const cl_uint nP = static_cast<cl_uint>(P);
    constants.set("n_problems", nP).set("prob_k", b_k).set("state", state).set("cparams", b_const);
    for (Routine* kk : {&estep, &loglik}) {
      set_grid_args(*kk, f.layout, f.set.grid);
      kk->set("weights", b_weights).set("prob_slice", b_slice).set("prob_k", b_k).set("status", status)
          .set("cparams", b_const);
    }
    estep.set("partials", b_partials);
    loglik.set("partials", ll);
    mstep.set("n_problems", nP).set("G", static_cast<cl_uint>(n_chunks)).set("max_iter", static_cast<cl_int>(s.iterations));
    mstep.set_real("tol", s.tolerance, w.fp64).set_real("cov_floor", cov_floor(f.set.grid, s), w.fp64)
        .set_real("min_weight", s.min_weight, w.fp64);
    mstep.set("prob_k", b_k).set("status", status).set("state", state).set("lprev", b_lprev)
        .set("partials", b_partials).set("cparams", b_const);
  }
};

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

void EmEngine::run_batches(const std::string& routine, const std::vector<ProblemBatch>& batches,
                           const std::vector<double>& cost, const std::function<void(const BatchWork&)>& work) {
  pool_->run(routine, cost, [&](const BatchRun& run) {
    const BatchWork w{batches[run.batch], run, devices_[run.device], uses_fp64(run.device), shape(run.device)};
    work(w);
  });
}

namespace {

// Runs EM on a batch: the constants, then E- and M-steps until every problem is done or
// the iterations run out, then the final log-likelihood, into `o`. The status is read every
// kStatusEvery iterations, every one when the run is watched (a run likely to lose to a
// faster device then stops after one iteration, not kStatusEvery). False when another
// device finished the batch first.
bool run_em(const FitCall& f, const BatchWork& w, const EmInputs& in, const EmSettings& s, EmOutputs& o) {
  const std::size_t P = w.size();
  const cl::CommandQueue& queue = *w.run.queue;
  auto t0 = std::chrono::steady_clock::now();
  try {
    EmRoutines r(build_program(w.device, "em", em_program_options(w.bucket(), w.shape, w.fp64, f.layout.map)), f, w, in, o, s);
    const cl::NDRange e_global(f.layout.chunks * static_cast<std::size_t>(w.shape.wg), P);
    const cl::NDRange e_local(static_cast<std::size_t>(w.shape.wg), 1);
    r.constants.run(queue, cl::NDRange(P));
    for (int it = 1; it <= s.iterations; ++it) {
      if (w.run.cancelled()) break;  // another device finished this batch
      r.estep.run(queue, e_global, e_local);
      r.mstep.set("iter", static_cast<cl_int>(it));
      r.mstep.run(queue, cl::NDRange(P));
      ++o.launched;
      if ((w.run.watched() || it % kStatusEvery == 0) && it < s.iterations) {
        queue.enqueueReadBuffer(r.status, CL_TRUE, 0, o.status.size() * sizeof(int), o.status.data());
        bool all = true;
        for (std::size_t i = 0; i < P && all; ++i) all = o.status[2 * i] != 0;
        if (all) break;
      }
    }
    if (w.run.cancelled()) {
      queue.finish();
      return false;
    }
    queue.finish();
    o.iterate_seconds = seconds_since(t0);
    t0 = std::chrono::steady_clock::now();
    r.loglik.run(queue, e_global, e_local);
    queue.enqueueReadBuffer(r.status, CL_FALSE, 0, o.status.size() * sizeof(int), o.status.data());
    queue.enqueueReadBuffer(r.state, CL_FALSE, 0, o.state.size(), o.state.data());
    queue.enqueueReadBuffer(r.ll, CL_TRUE, 0, o.ll.size(), o.ll.data());
    o.finish_seconds = seconds_since(t0);
  } catch (const cl::Error& e) {
    throw_device_error(e, "EM batch on " + w.device.info().label());
  }
  return w.run.claim();
}

// The results of a batch's problems from what its run read back.
void store_results(FitCall& f, const BatchWork& w, const EmOutputs& o) {
  const std::size_t K = static_cast<std::size_t>(w.bucket()), nstate = 6 * K, n_chunks = f.layout.chunks;
  const bool fp64 = w.fp64;
  for (std::size_t i = 0; i < w.size(); ++i) {
    const std::size_t pi = w.batch.items[i];
    const EmTask& t = f.tasks[f.problems[pi].task];
    EmResult& r = f.results[pi];
    r.iterations = o.status[2 * i + 1];
    Gmm& g = r.gmm;
    g.weight.resize(t.k);
    g.mean.resize(2 * t.k);
    g.cov.resize(3 * t.k);
    for (int j = 0; j < t.k; ++j) {
      const std::size_t b = i * nstate;
      g.weight[j] = unpack(o.state, b + 0 * K + j, fp64);
      g.mean[2 * j] = unpack(o.state, b + 1 * K + j, fp64);
      g.mean[2 * j + 1] = unpack(o.state, b + 2 * K + j, fp64);
      g.cov[3 * j] = unpack(o.state, b + 3 * K + j, fp64);
      g.cov[3 * j + 1] = unpack(o.state, b + 4 * K + j, fp64);
      g.cov[3 * j + 2] = unpack(o.state, b + 5 * K + j, fp64);
    }
    if (o.status[2 * i] == 2) {
      r.ok = false;
      r.loglik = -std::numeric_limits<double>::infinity();
      r.failure = "numerical failure (non-finite log-likelihood or no responsibility mass) after " +
                  std::to_string(r.iterations) + " iterations";
    } else {
      double l = 0;
      for (std::size_t c = 0; c < n_chunks; ++c) l += unpack(o.ll, i * n_chunks + c, fp64);
      r.loglik = l;
      r.ok = std::isfinite(l);
      if (!r.ok) r.failure = "non-finite final log-likelihood";
    }
    if (--f.remaining[f.problems[pi].task] == 0 && f.progress) f.progress->advance(1);
  }
}

// The best restart per task (the first of equal log-likelihoods) into f.out.
void keep_best_restarts(FitCall& f) {
  std::vector<std::string> first_failure(f.tasks.size());
  for (std::size_t pi = 0; pi < f.problems.size(); ++pi) {
    const std::size_t ti = f.problems[pi].task;
    EmResult& r = f.results[pi];
    if (!r.ok) {
      if (first_failure[ti].empty()) first_failure[ti] = r.failure;
      continue;
    }
    if (!f.out[ti].ok || r.loglik > f.out[ti].loglik) f.out[ti] = std::move(r);
  }
  for (std::size_t ti = 0; ti < f.tasks.size(); ++ti)
    if (!f.out[ti].ok && f.out[ti].failure.empty()) f.out[ti].failure = "every restart failed: " + first_failure[ti];
}

}  // namespace

std::vector<EmResult> EmEngine::fit(const SliceSet& set, const std::vector<EmTask>& tasks,
                                    Progress* progress) {
  if (!calibrated_) calibrate();
  const auto fit_start = std::chrono::steady_clock::now();
  timing_ = EmTiming{};
  validate_slices(set);
  validate_tasks(set, tasks);
  const SliceGrid& grid = set.grid;
  FitCall f(set, tasks, progress);
  const std::vector<Problem>& problems = f.problems;
  const std::size_t stride = f.layout.stride;

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
  std::vector<std::pair<int, std::vector<std::size_t>>> lists;
  for (auto& [key, list] : groups) lists.emplace_back(key.bucket, std::move(list));
  const std::vector<ProblemBatch> batches = plan_batches(lists, stride, 0, device_limit(), budget());
  std::vector<double> cost;
  for (const ProblemBatch& b : batches) {
    const EmSettings& s = tasks[problems[b.items.front()].task].settings;
    cost.push_back(static_cast<double>(b.items.size()) * static_cast<double>(stride) * b.bucket * s.iterations);
  }
  timing_.batches = batches.size();

  run_batches("em", batches, cost, [&](const BatchWork& w) {
    const EmSettings& s = f.task_of(w, 0).settings;
    const auto t0 = std::chrono::steady_clock::now();
    const EmInputs in(f, w);
    const double init_s = seconds_since(t0);
    EmOutputs o;
    o.status.assign(2 * w.size(), 0);
    o.state = pack(in.state, w.fp64);
    o.ll.resize(w.size() * f.layout.chunks * (w.fp64 ? 8 : 4));
    if (!run_em(f, w, in, s, o)) return;  // another device finished this batch first
    {
      std::lock_guard<std::mutex> lock(f.timing_mutex);
      timing_.init_seconds += init_s;
      timing_.iterate_seconds += o.iterate_seconds;
      timing_.finish_seconds += o.finish_seconds;
      timing_.iterations += o.launched;
    }
    store_results(f, w, o);
  });
  timing_.repeated = pool_->repeated();
  keep_best_restarts(f);
  timing_.seconds = seconds_since(fit_start);
  return std::move(f.out);
}

}  // namespace bsdfmix
