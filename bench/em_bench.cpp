// `bsdfmix bench em`: the EM throughput benchmark (bench/README.md).
#include "bench/em_bench.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "bench/machine_peak.hpp"
#include "bench/peer_runner.hpp"
#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "core/progress.hpp"
#include "device/device.hpp"
#include "fit/em.hpp"
#include "fit/em_internal.hpp"
#include "fit/synthetic.hpp"

namespace bsdfmix::bench {

namespace {

struct Row {
  std::string impl;
  int k = 0;
  std::size_t cells = 0, slices = 0;
  int iterations = 0;
  double seconds_per_iteration = 0;  // the fastest of `reps` timed runs
  int reps = 0;
  int threads = 0;    // worker threads (CPU), or compute units of the OpenCL device(s)
  std::string build;  // how the timed code was compiled
  double pc_per_s() const {
    return static_cast<double>(cells) * k * static_cast<double>(slices) / seconds_per_iteration;
  }
};

// Floating-point operations per point-component update in em_estep, counted from
// kernels/em.cl (an FMA counts 2; compares, selects, fmax and integer ops count 0):
//   log-density pass: dt, dp, the two wrap adds, cp3 * dp, dp * dp, 3 FMAs  = 12
//   responsibility:   E - m, exp2_neg (3 adds for the rounding and f, 5 FMAs of
//                     the degree-5 polynomial = 13), s += r                  = 15
//   statistics pass:  f * E, rw * dt, rw * dp, 3 adds, 3 FMAs (dt and dp
//                     kept from the first pass)                             = 12
// 39 flops in 28 arithmetic instructions (11 of them FMAs), beside 9 compares,
// selects, fmax and integer ops. Per-cell work (coordinates, w / s, log2) is
// amortized over K and not counted (nor the 4 flops the GPU layout, VEC 1, spends
// recomputing dt and dp: the percentage is a CPU's). Keep in step with the kernel.
constexpr double kFlopsPerUpdate = 39.0;

// How the host code (bsdfmix, the CPU reference) was compiled: set by bench/CMakeLists.txt.
#ifdef BSDFMIX_CXX_BUILD
const char* const kHostBuild = BSDFMIX_CXX_BUILD;
#else
const char* const kHostBuild = "unknown";
#endif

// A CSV field, quoted where it holds a comma, a quote or a line break.
std::string csv_field(const std::string& v) {
  if (v.find_first_of(",\"\n\r") == std::string::npos) return v;
  std::string out = "\"";
  for (char c : v) {
    if (c == '"') out += '"';
    out += c;
  }
  return out + "\"";
}

}  // namespace

void bench_em(const EmBenchOptions& o, const std::string& device_selector, bool quiet) {
  if (o.k < 1 || o.k > kEmMaxK) throw ConfigError("bench em: --k must be in 1.." + std::to_string(kEmMaxK));
  if (o.iterations < 2) throw ConfigError("bench em: --iterations must be at least 2");
  if (o.slices < 1) throw ConfigError("bench em: --slices must be at least 1");
  if (o.repeat < 1) throw ConfigError("bench em: --repeat must be at least 1");
  prepare_output(o.csv);
  const double load_before = load_average_1min();  // before this run adds its own load

  // The data: 90 x 180 fiber slices, each a synthetic multi-lobe mixture.
  SliceSet set;
  set.grid = make_slice_grid(Domain::Fiber, 90, 180);
  for (int s = 0; s < o.slices; ++s)
    set.weights.push_back(mixture_weights(set.grid, synthetic_lobes(Domain::Fiber, 6, o.seed + s)));
  const std::size_t cells = set.grid.cells();
  EmSettings settings;
  settings.iterations = o.iterations;
  settings.tolerance = 0;  // exactly `iterations` iterations
  settings.restarts = 1;
  settings.seed = o.seed;
  std::vector<EmTask> tasks;
  for (int s = 0; s < o.slices; ++s) tasks.push_back({static_cast<std::size_t>(s), o.k, settings, {}});

  std::vector<Row> rows;
  auto devices = select_devices(device_selector);
  std::string device_names, device_versions, kernel_build;
  int device_units = 0;
  bool all_cpu = true;
  for (const auto& d : devices) {
    const auto& info = d.info();
    device_names += (device_names.empty() ? "" : " + ") + info.name;
    device_versions += (device_versions.empty() ? "" : " + ") + info.version + " (driver " + info.driver + ")";
    kernel_build += (kernel_build.empty() ? "" : " + ") + info.platform + " " + info.driver;
    device_units += static_cast<int>(info.compute_units);
    all_cpu = all_cpu && info.is_cpu();
  }
  // The options are those host/fit/em_engine.cpp and build_program pass; PoCL's CPU
  // devices compile with LLVM for the host CPU (the device name names the target).
  kernel_build = "kernels: OpenCL C built at run time by " + kernel_build + " (-cl-std=CL1.2 -cl-denorms-are-zero" +
                 (all_cpu && kernel_build.find("Portable Computing Language") != std::string::npos
                      ? "; PoCL: LLVM for the host CPU"
                      : "") +
                 "); host: " + kHostBuild;
  EmEngine engine(std::move(devices), o.queues, EngineOptions{parse_precision(o.precision), o.pool_log});

  // Warm-up (kernel build), then the timed fit.
  {
    std::vector<EmTask> warm = {tasks.front()};
    warm.front().settings.iterations = 2;
    engine.fit(set, warm);
  }
  // Every timed fit must have run all its iterations, or the time means nothing.
  auto check = [&](const std::vector<EmResult>& results, int iterations) {
    for (std::size_t i = 0; i < results.size(); ++i)
      if (!results[i].ok || results[i].iterations != iterations)
        throw Error("bench em: the fit of slice " + std::to_string(i) + " stopped after " +
                    std::to_string(results[i].iterations) + " of " + std::to_string(iterations) +
                    " iterations" + (results[i].ok ? "" : ": " + results[i].failure));
  };
  // Seconds per iteration of bsdfmix: the difference of fits of I and 1 iterations, over
  // I - 1. A batch's setup (its buffers, the upload of the weights, the first constants)
  // is then not counted, as the peers and the reference time their iterations only
  // (bench/peers/README.md). One queue: the iterations' time (the engine's iterate_seconds,
  // setup included); several: wall times, since the queues' batches overlap. `setup`
  // keeps what the one-iteration fit took beyond one iteration.
  double setup = 0;
  auto time_bsdfmix = [&]() {
    auto seconds = [&]() {
      return engine.queue_count() == 1 ? engine.last_timing().iterate_seconds : engine.last_timing().seconds;
    };
    std::vector<EmTask> one = tasks;
    for (auto& task : one) task.settings.iterations = 1;
    check(engine.fit(set, one), 1);
    const double t1 = seconds();
    check(engine.fit(set, tasks), o.iterations);
    const double per_iteration = (seconds() - t1) / (o.iterations - 1);
    setup = t1 - per_iteration;
    return per_iteration;
  };

  // The CPU reference and the peers fit the first slice.
  const em_detail::PreparedSlice slice0 = em_detail::prepare_slice(set, 0);
  Gmm ref_init;
  if (o.reference) ref_init = em_detail::initialize(set.grid, slice0.w, 0, o.k, 0, settings);

  std::vector<Peer> peers;
  std::unique_ptr<TempFile> data;  // the first slice, as the peers read it
  if (o.peers) {
    data = std::make_unique<TempFile>();
    write_peer_data(data->path(), set.grid, slice0.w);
    peers = find_peers(data->path(), cells, o.k, o.iterations, o.seed, quiet);
  }

  // `repeat` rounds, each timing every row once (bsdfmix, the reference, each peer)
  // and measuring the FMA peak of the CPU (all logical CPUs at once): on a shared
  // machine a burst of other work then spoils one run of each row rather than every
  // run of one row. Each row keeps its fastest run, the peak its highest.
  const std::string cpu = cpu_model_name();
  const int cpus = logical_cpus();
  double spi = 0, ref_seconds = 0, best_setup = 0;
  EmTiming timing;
  FmaPeak peak;
  for (int rep = 0; rep < o.repeat; ++rep) {
    if (!quiet) log_line("bench: round " + std::to_string(rep + 1) + " of " + std::to_string(o.repeat));
    const double t = time_bsdfmix();
    if (rep == 0 || t < spi) {
      spi = t;
      timing = engine.last_timing();
      best_setup = setup;
    }
    if (o.reference) {
      double tr = 0;
      em_detail::run_reference(set.grid, slice0.w, ref_init, settings, &tr);
      if (rep == 0 || tr < ref_seconds) ref_seconds = tr;
    }
    for (auto& p : peers) {
      if (p.failed) continue;
      PeerTiming r;
      if (!run_peer(p, r)) {
        p.failed = true;
        log_line("bench: peer " + p.name + " dropped (failed in round " + std::to_string(rep + 1) + ")");
        continue;
      }
      if (p.reps == 0 || r.seconds_per_iteration < p.best.seconds_per_iteration) p.best = r;
      ++p.reps;
    }
    const FmaPeak pk = measure_fma_peak(cpus, 1);
    if (rep == 0 || pk.flops_per_s > peak.flops_per_s) peak = pk;
  }

  rows.push_back({"bsdfmix (" + device_names + ")", o.k, cells, static_cast<std::size_t>(o.slices), o.iterations, spi,
                  o.repeat, device_units, kernel_build});
  if (o.reference)
    rows.push_back({"cpu_reference", o.k, cells, 1, o.iterations, ref_seconds / o.iterations, o.repeat, 1, kHostBuild});
  for (const auto& p : peers) {
    if (p.failed) continue;
    // The row is named by the peer (armadillo_generic prints "armadillo"); one slice, and
    // every peer pins itself to one thread (bench/peers/README.md).
    rows.push_back({p.name, p.best.k, p.best.cells, 1, p.best.iterations, p.best.seconds_per_iteration, p.reps, 1,
                    p.build});
  }

  // The percentage of the FMA peak only where the kernels ran on this CPU.
  const double ours = rows.front().pc_per_s();
  const double achieved = ours * kFlopsPerUpdate;
  const bool have_pct = all_cpu && peak.flops_per_s > 0;
  const double pct = have_pct ? 100 * achieved / peak.flops_per_s : 0;

  // CSV and table.
  std::ostringstream csv;
  csv << "impl,k,cells,slices,iterations,seconds_per_iteration,pc_per_s,reps,threads,build,"
         "cpu_model,logical_cpus,opencl_device,opencl_version,fma_peak_gflops,fma_peak_isa,"
         "loadavg_before,flops_per_update,gflops,pct_of_fma_peak\n";
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const Row& r = rows[i];
    char line[512];
    std::snprintf(line, sizeof line, "%s,%d,%zu,%zu,%d,%.6g,%.6g,%d,%d,", csv_field(r.impl).c_str(), r.k, r.cells,
                  r.slices, r.iterations, r.seconds_per_iteration, r.pc_per_s(), r.reps, r.threads);
    csv << line << csv_field(r.build) << ',' << csv_field(cpu) << ',' << cpus << ',' << csv_field(device_names)
        << ',' << csv_field(device_versions) << ',';
    if (peak.flops_per_s > 0) {
      std::snprintf(line, sizeof line, "%.4g", peak.flops_per_s / 1e9);
      csv << line;
    }
    std::snprintf(line, sizeof line, ",%s,%.2f,", csv_field(peak.isa).c_str(), load_before);
    csv << line;
    if (i == 0) {  // the flop count is the kernel's: bsdfmix row only
      std::snprintf(line, sizeof line, "%.0f,%.4g,", kFlopsPerUpdate, achieved / 1e9);
      csv << line;
      if (have_pct) {
        std::snprintf(line, sizeof line, "%.3g", pct);
        csv << line;
      }
    } else {
      csv << ",,";
    }
    csv << '\n';
  }
  write_text_atomic(o.csv, csv.str());

  std::printf("EM throughput, K = %d, %zu-cell slices (90 x 180), %d iterations, best of %d\n", o.k, cells,
              o.iterations, o.repeat);
  std::printf("machine: %s, %d logical CPUs, 1-minute load average %.2f before the run; OpenCL: %s, %s\n",
              cpu.c_str(), cpus, load_before, device_names.c_str(), device_versions.c_str());
  std::printf("%-48s %7s %7s %9s %13s %17s %10s %9s\n", "impl", "threads", "slices", "cells", "s/iteration",
              "ms/slice-iter", "G pc/s", "vs ours");
  for (const auto& r : rows)
    std::printf("%-48s %7d %7zu %9zu %13.6f %17.4f %10.4f %9.4f\n", r.impl.c_str(), r.threads, r.slices, r.cells,
                r.seconds_per_iteration, 1e3 * r.seconds_per_iteration / static_cast<double>(r.slices),
                r.pc_per_s() / 1e9, r.pc_per_s() / ours);
  for (const auto& r : rows) std::printf("build of %s: %s\n", r.impl.c_str(), r.build.c_str());
  if (peak.flops_per_s > 0)
    std::printf("measured FMA peak: %.1f GFLOP/s (%d threads x %d chains of %s FMAs, best of %d)\n",
                peak.flops_per_s / 1e9, peak.threads, peak.chains, peak.isa.c_str(), o.repeat);
  else
    std::printf("FMA peak: %s\n", peak.isa.c_str());
  if (have_pct)
    std::printf("arithmetic: %.0f flops per update (counted from kernels/em.cl) -> %.1f GFLOP/s: %.1f%% of the "
                "measured FMA peak\n",
                kFlopsPerUpdate, achieved / 1e9, pct);
  else
    std::printf("arithmetic: %.0f flops per update (counted from kernels/em.cl) -> %.1f GFLOP/s (no peak measured "
                "for this device)\n",
                kFlopsPerUpdate, achieved / 1e9);
  std::printf("profile (timed fit): host init %.3f s, iterations %.3f s over %zu batch(es), final log-likelihood "
              "and read-back %.3f s, precision %s; batch setup (not in s/iteration) %.4f s\n",
              timing.init_seconds, timing.iterate_seconds, timing.batches, timing.finish_seconds,
              engine.uses_fp64(0) ? "fp64" : "fp32", std::max(0.0, best_setup));
  std::printf("csv: %s\n", o.csv.c_str());
}

}  // namespace bsdfmix::bench
