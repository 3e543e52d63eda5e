// `bsdfmix tune`: candidate kernel shapes timed per device, the fastest recorded.
#include "bench/shape_tune.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "device/shapes.hpp"
#include "fit/em.hpp"
#include "fit/synthetic.hpp"

namespace bsdfmix::bench {

namespace {

// The slices and tasks every shape is timed on: known fiber-like mixtures, `slices` of them,
// each fitted at K with one restart and a fixed iteration count.
void workload(const TuneOptions& o, SliceSet& set, std::vector<EmTask>& tasks) {
  set.grid = make_slice_grid(Domain::Fiber, o.theta, 2 * o.theta);
  for (int s = 0; s < o.slices; ++s) {
    set.weights.push_back(mixture_weights(set.grid, synthetic_lobes(Domain::Fiber, 4, 1000 + s)));
    EmTask t;
    t.slice = static_cast<std::size_t>(s);
    t.k = o.k;
    t.settings.iterations = 20;
    t.settings.tolerance = 0;
    t.settings.restarts = 1;
    tasks.push_back(t);
  }
}

double best_seconds(EmEngine& engine, const SliceSet& set, const std::vector<EmTask>& tasks, int runs,
                    std::vector<EmResult>& results) {
  results = engine.fit(set, tasks);  // builds the programs outside the timing
  double best = 1e300;
  for (int r = 0; r < runs; ++r) {
    const auto t0 = std::chrono::steady_clock::now();
    results = engine.fit(set, tasks);
    best = std::min(best, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  }
  return best;
}

// Replaces the entry of `info` in `path` (or adds it), keeping every other line.
void record(const std::string& path, const DeviceInfo& info, const std::string& entry) {
  std::string kept = "# bsdfmix tune: <device>\t<driver>\t<vec>\t<wg>\t<note>; read where BSDFMIX_SHAPES names this file\n";
  if (const auto old = read_text(path)) {
    std::istringstream in(*old);
    kept.clear();
    for (std::string line; std::getline(in, line);)
      if (line.rfind(info.name + "\t" + info.driver + "\t", 0) != 0) kept += line + "\n";
  }
  write_text_atomic(path, kept + entry + "\n");
}

}  // namespace

void tune_shapes(const TuneOptions& o, const std::string& device_selector) {
  const int phi = 2 * o.theta;
  SliceSet set;
  std::vector<EmTask> tasks;
  workload(o, set, tasks);
  for (const Device& dev : select_devices(device_selector)) {
    const DeviceInfo& info = dev.info();
    const ShapeChoice current = choose_shape(info);
    std::printf("[%d] %s, driver %s: now %s (%s)\n", info.index, info.name.c_str(), info.driver.c_str(),
                current.shape.label().c_str(), current.source.c_str());
    EmEngine reference_engine({dev}, 1, o.engine);  // the device's shape from its table row or tuned entry
    std::vector<EmResult> reference;
    best_seconds(reference_engine, set, tasks, 0, reference);
    KernelShape best;
    double best_s = 1e300;
    for (const KernelShape& shape : shape_candidates(info)) {
      EmEngine engine({dev}, 1, o.engine);
      engine.set_shape(shape);
      std::vector<EmResult> results;
      double s = 0;
      try {
        s = best_seconds(engine, set, tasks, o.runs, results);
      } catch (const DeviceError& e) {
        std::printf("  %-16s does not run: %s\n", shape.label().c_str(), e.what());
        continue;
      }
      // The same fits within float rounding: the log-likelihoods of every slice.
      double worst = 0;
      for (std::size_t i = 0; i < results.size(); ++i)
        worst = std::max(worst, std::abs(results[i].loglik - reference[i].loglik) / std::max(1.0, std::abs(reference[i].loglik)));
      const bool agrees = worst < 1e-4;
      std::printf("  %-16s %9.4f s  loglik within %.1e of the default%s\n", shape.label().c_str(), s, worst,
                  agrees ? "" : ": DISAGREES, not chosen");
      if (agrees && s < best_s) {
        best_s = s;
        best = shape;
      }
    }
    if (best_s >= 1e300) throw DeviceError("tune: no shape ran on " + info.label());
    char note[128];
    std::snprintf(note, sizeof note, "K %d, %d slices of %dx%d: %.4f s", o.k, o.slices, o.theta, phi, best_s);
    const std::string entry = shape_entry(info, best, note);
    std::printf("  fastest: %s\n  entry: %s\n", best.label().c_str(), entry.c_str());
    if (!o.out.empty()) {
      record(o.out, info, entry);
      std::printf("  recorded in %s (export BSDFMIX_SHAPES=%s)\n", o.out.c_str(), o.out.c_str());
    }
  }
}

}  // namespace bsdfmix::bench
