// `bsdfmix bench em`: the EM throughput benchmark (bench/README.md).
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "cli/commands.hpp"
#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "core/progress.hpp"
#include "device/device.hpp"
#include "fit/em.hpp"
#include "fit/em_internal.hpp"
#include "fit/synthetic.hpp"

namespace bsdfmix::cli {

namespace {

struct BenchOptions {
  int k = 50;
  std::string csv;
  int iterations = 20;
  int slices = 64;
  int queues = 1;
  int repeat = 3;
  std::string precision = "auto";
  bool peers = true;
  bool reference = true;
  std::uint64_t seed = 1;
};

struct Row {
  std::string impl;
  int k = 0;
  std::size_t cells = 0, slices = 0;
  int iterations = 0;
  double seconds_per_iteration = 0;
  double pc_per_s() const {
    return static_cast<double>(cells) * k * static_cast<double>(slices) / seconds_per_iteration;
  }
};

// Arithmetic operations per point-component update in em_estep, counted from the
// kernel source: 15 for the log-density (offsets, nearest-image wrap, quadratic
// form, running max), 2 + one exp2 for the responsibility, 18 for the six
// statistics (offsets again, scaling, 3 adds, 3 FMAs); an FMA counts as 2, exp2 as 1.
constexpr double kFlopsPerUpdate = 36.0;

std::string exe_dir() {
  char buf[4096];
  const ssize_t n = ::readlink("/proc/self/exe", buf, sizeof buf - 1);
  if (n <= 0) return ".";
  std::string p(buf, static_cast<std::size_t>(n));
  const auto slash = p.rfind('/');
  return slash == std::string::npos ? "." : p.substr(0, slash);
}

std::string shell_quote(const std::string& s) {
  std::string out = "'";
  for (char c : s) {
    if (c == '\'') out += "'\\''";
    else out += c;
  }
  return out + "'";
}

bool file_exists(const std::string& p) { return ::access(p.c_str(), F_OK) == 0; }

// SIMD float lanes of this CPU, from /proc/cpuinfo flags.
int cpu_simd_floats() {
  std::ifstream f("/proc/cpuinfo");
  std::string line;
  while (std::getline(f, line)) {
    if (line.rfind("flags", 0) != 0) continue;
    if (line.find(" avx512f") != std::string::npos) return 16;
    if (line.find(" avx") != std::string::npos) return 8;
    return 4;
  }
  return 4;
}

// Single-precision peak (FLOP/s) of a device, and how it was estimated.
double peak_flops(const Device& dev, std::string& how) {
  const auto& info = dev.info();
  const double mhz = dev.cl_device().getInfo<CL_DEVICE_MAX_CLOCK_FREQUENCY>();
  if (info.is_cpu()) {
    const int simd = cpu_simd_floats();
    char buf[256];
    std::snprintf(buf, sizeof buf, "%u cores x %.2f GHz x %d float lanes x 2 (one FMA per cycle)",
                  info.compute_units, mhz / 1000, simd);
    how = buf;
    return info.compute_units * mhz * 1e6 * simd * 2.0;
  }
  std::string vendor = info.vendor;
  std::transform(vendor.begin(), vendor.end(), vendor.begin(), ::tolower);
  if (vendor.find("nvidia") != std::string::npos) {
    char buf[256];
    std::snprintf(buf, sizeof buf, "%u SMs x %.2f GHz x 128 FP32 lanes x 2 (FMA)", info.compute_units, mhz / 1000);
    how = buf;
    return info.compute_units * mhz * 1e6 * 128 * 2.0;
  }
  how = "unknown for this device kind";
  return 0;
}

// Writes one slice as float32 (theta, phi, weight) triples; weights scaled to mean 1.
void write_peer_data(const std::string& path, const SliceGrid& grid, const std::vector<double>& w) {
  std::ofstream f(path, std::ios::binary);
  if (!f) throw IoError("bench: cannot write peer data " + path);
  double total = 0;
  for (double v : w) total += v;
  const double scale = static_cast<double>(w.size()) / total;
  const std::size_t np = grid.phi.size();
  for (std::size_t i = 0; i < w.size(); ++i) {
    const float v[3] = {static_cast<float>(grid.theta[i / np]), static_cast<float>(grid.phi[i % np]),
                        static_cast<float>(w[i] * scale)};
    f.write(reinterpret_cast<const char*>(v), sizeof v);
  }
  if (!f) throw IoError("bench: cannot write peer data " + path);
}

// Runs one peer program; false (with a note) when it is missing or fails.
bool run_peer(const std::string& name, const std::string& command, Row& row) {
  FILE* pipe = ::popen(command.c_str(), "r");
  if (!pipe) {
    log_line("bench: cannot start peer " + name);
    return false;
  }
  std::string out;
  char buf[512];
  while (std::fgets(buf, sizeof buf, pipe)) out += buf;
  const int status = ::pclose(pipe);
  const int code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  if (code == 3) {
    log_line("bench: peer " + name + " skipped: its library is not installed");
    return false;
  }
  if (code != 0) {
    log_line("bench: peer " + name + " failed with exit code " + std::to_string(code));
    return false;
  }
  std::string last, line;
  std::istringstream ss(out);
  while (std::getline(ss, line))
    if (!line.empty()) last = line;
  std::vector<std::string> f;
  std::istringstream ls(last);
  std::string field;
  while (std::getline(ls, field, ',')) f.push_back(field);
  try {
    if (f.size() != 5) throw std::invalid_argument("fields");
    row.impl = f[0];
    row.k = std::stoi(f[1]);
    row.cells = std::stoul(f[2]);
    row.slices = 1;
    row.iterations = std::stoi(f[3]);
    row.seconds_per_iteration = std::stod(f[4]);
    if (!(row.seconds_per_iteration > 0)) throw std::invalid_argument("time");
  } catch (const std::exception&) {
    log_line("bench: peer " + name + " printed an unreadable line: '" + last + "'");
    return false;
  }
  return true;
}

void bench_em(const BenchOptions& o, const Common& common) {
  if (o.k < 1 || o.k > kEmMaxK) throw ConfigError("bench em: --k must be in 1.." + std::to_string(kEmMaxK));
  if (o.iterations < 2) throw ConfigError("bench em: --iterations must be at least 2");
  if (o.slices < 1) throw ConfigError("bench em: --slices must be at least 1");
  if (o.repeat < 1) throw ConfigError("bench em: --repeat must be at least 1");
  prepare_output(o.csv);

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
  for (int s = 0; s < o.slices; ++s) tasks.push_back({static_cast<std::size_t>(s), o.k, settings});

  std::vector<Row> rows;
  auto devices = select_devices(common.device);
  const Device first = devices.front();
  std::string device_names;
  for (const auto& d : devices) device_names += (device_names.empty() ? "" : " + ") + d.info().name;
  EmEngine engine(std::move(devices), o.queues, parse_precision(o.precision));

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
  // The best of `repeat` timed fits (the machine may be shared).
  double spi = 0;
  EmTiming timing;
  for (int rep = 0; rep < o.repeat; ++rep) {
    double t;
    if (engine.queue_count() == 1) {
      check(engine.fit(set, tasks), o.iterations);
      t = engine.last_timing().iterate_seconds / o.iterations;
    } else {  // overlapping queues: difference of wall times of I and 1 iterations
      std::vector<EmTask> one = tasks;
      for (auto& task : one) task.settings.iterations = 1;
      check(engine.fit(set, one), 1);
      const double t1 = engine.last_timing().seconds;
      check(engine.fit(set, tasks), o.iterations);
      t = (engine.last_timing().seconds - t1) / (o.iterations - 1);
    }
    if (rep == 0 || t < spi) {
      spi = t;
      timing = engine.last_timing();
    }
  }
  rows.push_back({"bsdfmix (" + device_names + ")", o.k, cells, static_cast<std::size_t>(o.slices), o.iterations, spi});

  // The CPU reference on one slice.
  const em_detail::PreparedSlice slice0 = em_detail::prepare_slice(set, 0);
  if (o.reference) {
    const Gmm init = em_detail::initialize(set.grid, slice0.w, 0, o.k, 0, settings);
    double secs = 0;
    for (int rep = 0; rep < o.repeat; ++rep) {
      double t = 0;
      em_detail::run_reference(set.grid, slice0.w, init, settings, &t);
      if (rep == 0 || t < secs) secs = t;
    }
    rows.push_back({"cpu_reference", o.k, cells, 1, o.iterations, secs / o.iterations});
  }

  // Peers on the same first slice.
  if (o.peers) {
    char tmpl[] = "/tmp/bsdfmix_bench_XXXXXX";
    const int fd = ::mkstemp(tmpl);
    if (fd < 0) throw IoError("bench: cannot create a temporary file in /tmp");
    ::close(fd);
    const std::string data = tmpl;
    write_peer_data(data, set.grid, slice0.w);
    const std::string args = " --data " + shell_quote(data) + " --n " + std::to_string(cells) + " --k " +
                             std::to_string(o.k) + " --iterations " + std::to_string(o.iterations) +
                             " --seed " + std::to_string(o.seed);
    const std::string src = BSDFMIX_SOURCE_DIR;
    struct Peer {
      std::string name, program;
      bool python;
    };
    const std::vector<Peer> peers = {
        {"pomegranate", src + "/bench/peers/em_pomegranate.py", true},
        {"scikit-learn", src + "/bench/peers/em_sklearn.py", true},
        {"armadillo", exe_dir() + "/bench/peers/bsdfmix_peer_armadillo", false},
    };
    for (const auto& p : peers) {
      if (!file_exists(p.program)) {
        log_line("bench: peer " + p.name + " not found (" + p.program + ")");
        continue;
      }
      if (!common.quiet) log_line("bench: running peer " + p.name);
      const std::string cmd =
          (p.python ? std::string("/usr/bin/python3 ") : std::string()) + shell_quote(p.program) + args +
          (common.quiet ? " 2>/dev/null" : "");
      Row r;
      if (run_peer(p.name, cmd, r)) rows.push_back(r);
    }
    ::unlink(data.c_str());
  }

  // CSV and table.
  std::ostringstream csv;
  csv << "impl,k,cells,slices,iterations,seconds_per_iteration,pc_per_s\n";
  for (const auto& r : rows) {
    char line[512];
    std::snprintf(line, sizeof line, "%s,%d,%zu,%zu,%d,%.6g,%.6g\n", r.impl.c_str(), r.k, r.cells, r.slices,
                  r.iterations, r.seconds_per_iteration, r.pc_per_s());
    csv << line;
  }
  write_text_atomic(o.csv, csv.str());

  const double ours = rows.front().pc_per_s();
  std::printf("EM throughput, K = %d, %zu-cell slices (90 x 180), %d iterations\n", o.k, cells, o.iterations);
  std::printf("%-48s %7s %9s %13s %17s %10s %9s\n", "impl", "slices", "cells", "s/iteration",
              "ms/slice-iter", "G pc/s", "vs ours");
  for (const auto& r : rows)
    std::printf("%-48s %7zu %9zu %13.6f %17.4f %10.4f %9.4f\n", r.impl.c_str(), r.slices, r.cells,
                r.seconds_per_iteration, 1e3 * r.seconds_per_iteration / static_cast<double>(r.slices),
                r.pc_per_s() / 1e9, r.pc_per_s() / ours);
  std::string how;
  // CPU devices share the host's cores (PoCL presents one CPU as several devices):
  // count the host once; other devices add up.
  double peak = peak_flops(first, how);
  bool all_cpu = true;
  for (const auto& d : engine.devices()) all_cpu = all_cpu && d.info().is_cpu();
  if (!all_cpu) {
    peak = 0;
    for (const auto& d : engine.devices()) {
      std::string h;
      peak += peak_flops(d, h);
    }
  }
  const double achieved = ours * kFlopsPerUpdate;
  if (peak > 0)
    std::printf("arithmetic: %.0f flops per update -> %.1f GFLOP/s of a %.1f GFLOP/s single-precision peak "
                "(%s): %.1f%% of peak\n",
                kFlopsPerUpdate, achieved / 1e9, peak / 1e9, how.c_str(), 100 * achieved / peak);
  else
    std::printf("arithmetic: %.0f flops per update -> %.1f GFLOP/s (peak %s)\n", kFlopsPerUpdate,
                achieved / 1e9, how.c_str());
  std::printf("profile (timed fit): host init %.3f s, iterations %.3f s over %zu batch(es), final log-likelihood "
              "and read-back %.3f s, precision %s\n",
              timing.init_seconds, timing.iterate_seconds, timing.batches, timing.finish_seconds,
              engine.uses_fp64(0) ? "fp64" : "fp32");
  std::printf("csv: %s\n", o.csv.c_str());
}

}  // namespace

void add_bench(CLI::App& app, Common& common) {
  auto* sub = app.add_subcommand("bench", "benchmarks");
  auto* em = sub->add_subcommand("em", "EM throughput against the CPU reference and peer libraries");
  static BenchOptions o;
  em->add_option("--k", o.k, "Gaussian components")->capture_default_str();
  em->add_option("--csv", o.csv, "CSV output file")->required();
  em->add_option("--iterations", o.iterations, "EM iterations timed")->capture_default_str();
  em->add_option("--slices", o.slices, "90 x 180 slices fitted by bsdfmix (peers and reference: 1)")
      ->capture_default_str();
  em->add_option("--repeat", o.repeat, "timed runs of bsdfmix and the reference; the fastest is kept")
      ->capture_default_str();
  em->add_option("--queues", o.queues, "work queues per device")->capture_default_str();
  em->add_option("--precision", o.precision, "auto, fp32 or fp64 accumulation")->capture_default_str();
  em->add_option("--seed", o.seed, "data and initialization seed")->capture_default_str();
  em->add_flag("--peers,!--no-peers", o.peers, "run the peer programs of bench/peers (default: on)");
  em->add_flag("--reference,!--no-reference", o.reference, "time the CPU reference (default: on)");
  add_common_options(*em, common);
  sub->require_subcommand(1);
  em->callback([&common] {
    if (common.quiet) Progress::set_enabled(false);
    bench_em(o, common);
  });
}

}  // namespace bsdfmix::cli
