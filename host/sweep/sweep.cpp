// The file sweep: plan, checkpoint and resume, batches fitted here or by a farm, outputs.
#include "sweep/sweep.hpp"

#include <algorithm>
#include <chrono>
#include <ctime>
#include <filesystem>
#include <thread>
#include <unordered_map>

#include "core/atomic_file.hpp"
#include "core/hash.hpp"
#include "core/output_lock.hpp"
#include "core/progress.hpp"
#include "device/device.hpp"
#include "fit/em.hpp"
#include "io/table.hpp"
#include "sweep/batch_fitter.hpp"
#include "sweep/batch_lanes.hpp"
#include "sweep/checkpoint.hpp"
#include "sweep/criterion.hpp"
#include "sweep/map_choice.hpp"
#include "sweep/slice_plan.hpp"
#include "sweep/slice_source.hpp"
#include "sweep/sweep_outputs.hpp"
#include "sweep/sweep_warnings.hpp"

namespace bsdfmix {

struct BatchWorker::Impl {
  Impl(const std::string& table_path, const FitSettings& fit, const std::string& device_selector,
       const EngineOptions& engine_options)
      : fit_settings(fit), reader(table_path), slices(reader), devices(select_devices(device_selector)),
        engine(devices, 1, engine_options), fitter(slices, fit_settings, engine, joined_names(devices)) {}
  FitSettings fit_settings;  // the fitter reads its map at each batch
  TableReader reader;
  TableSlices slices;
  const std::vector<Device> devices;
  EmEngine engine;
  BatchFitter fitter;
};

BatchWorker::BatchWorker(const std::string& table_path, const FitSettings& fit, const std::string& device_selector,
                         const EngineOptions& engine)
    : impl_(std::make_unique<Impl>(table_path, fit, device_selector, engine)) {}
BatchWorker::~BatchWorker() = default;
BatchPart BatchWorker::fit(const std::vector<SliceRef>& batch, const std::string& map) {
  impl_->fit_settings.map = map;
  return impl_->fitter.fit(batch);
}

namespace {

// The map of a file sweep (choose_map), or the choice kept at `path` under `key` by an
// earlier run of the same sweep; a new choice is kept there unless its probe fitted every
// slice.
MapChoice settled_map(const SliceSource& source, const std::string& table_path, const std::vector<SliceRef>& plan,
                      const FitSettings& fit, const std::vector<Device>& devices,
                      const EngineOptions& engine_options, const std::string& path, const std::string& key) {
  if (map_probed(fit, source.meta().domain))
    if (const std::optional<std::string> kept = read_text(path))
      if (std::optional<MapChoice> c = read_map_choice(*kept, key)) {
        log_line("fit " + table_path + ": map " + c->text() + " (kept from the interrupted run)");
        return std::move(*c);
      }
  MapChoice c = choose_map(source, plan, fit, devices, engine_options, "fit " + table_path);
  if (c.probed > 0 && !c.whole) write_text_atomic(path, map_choice_record(c, key));
  return c;
}

// Checks the committed parts against the table: one rewritten in place (same path, size
// and source) is caught by its content.
void verify_parts(Checkpoint& checkpoint, const SliceSource& source, const std::vector<SliceRef>& plan) {
  std::unordered_map<std::size_t, const SliceRef*> planned;
  for (const SliceRef& r : plan) planned.emplace(r.index, &r);
  checkpoint.verify([&](const std::vector<std::size_t>& indices) {
    std::vector<const SliceRef*> refs;
    for (std::size_t index : indices) {
      const auto at = planned.find(index);
      if (at == planned.end()) return std::string("not planned");
      refs.push_back(at->second);
    }
    return slices_hash(source, refs);
  });
}

void log_plan(const std::string& table_path, std::size_t slices, const FitSettings& fit, const std::string& devices) {
  const std::vector<int> ks = candidate_ks(fit.k_min, fit.k_max);
  log_line("fit " + table_path + ": " + std::to_string(slices) + " slice(s), " +
           (fit.k_min != fit.k_max ? std::to_string(ks.size()) + " candidate K in [" + std::to_string(fit.k_min) +
                                         ", " + std::to_string(fit.k_max) + "]"
                                   : "K = " + std::to_string(fit.k_min)) +
           ", on " + devices);
}

}  // namespace

SweepSummary run_sweep(const std::string& table_path, const FitSettings& fit, const std::string& device_selector,
                       const SweepOptions& options) {
  const auto t_start = std::chrono::steady_clock::now();
  const std::clock_t cpu_start = std::clock();  // this process's CPU time, every thread's
  const OutputLock lock(fit.output);  // a second run on the same output fails here, at once
  TableReader reader(table_path);
  const TableSlices source(reader);
  const TableMeta& meta = reader.meta();
  const std::vector<SliceRef> plan = plan_fit_slices(meta, fit);
  for (const auto* out : {&fit.output, &fit.report, &fit.search_report}) prepare_output(*out, 1 << 20);

  const std::vector<Device> devices = select_devices(device_selector);
  const std::string device_names = joined_names(devices);
  EmEngine engine(devices, 1, options.engine);

  const std::size_t batch = batch_size(plan.size(), fit, meta.cells_per_slice());
  // fit.map auto: the probe's map (sweep/map_choice.hpp), kept beside the output until the
  // file is written, so that a resumed fit takes it again; the fits use it, the file
  // records the settings as given.
  const std::string choice_path = fit.output + ".map";
  std::string key;  // the choice's: the sweep's fingerprint with the settings as given
  if (map_probed(fit, meta.domain)) {
    const std::string as_given = sweep_fingerprint(table_path, meta, plan, fit, batch, engine, devices);
    key = Hash64().update(as_given.data(), as_given.size()).hex();
  }
  MapChoice choice = settled_map(source, table_path, plan, fit, devices, options.engine, choice_path, key);
  const FitSettings used = with_map(fit, choice.map);
  Checkpoint checkpoint(fit.output, sweep_fingerprint(table_path, meta, plan, used, batch, engine, devices));
  verify_parts(checkpoint, source, plan);

  // Batches are fixed ranges of the plan, so a resumed sweep rebuilds exactly the
  // batches it did not commit: the same problems, the same results.
  std::vector<std::vector<SliceRef>> batches;
  std::size_t resumed = 0;
  for (std::vector<SliceRef>& b : split_batches(plan, batch)) {
    if (choice.whole) break;  // the probe fitted every slice
    const bool done = std::all_of(b.begin(), b.end(), [&](const SliceRef& r) { return checkpoint.done(r.index); });
    if (done) resumed += b.size();
    else batches.push_back(std::move(b));
  }
  log_plan(table_path, plan.size(), fit, device_names);
  // The slices left: a resumed fit's rate and ETA count only what it fits itself.
  Progress progress("fit " + table_path + (resumed ? " (" + std::to_string(resumed) + " resumed)" : ""),
                    plan.size() - resumed, "slices");

  std::size_t committed = resumed;
  FitPhases phases = choice.whole ? choice.whole->phases : FitPhases{};  // of the fits in this process
  const bool stops = options.max_batches < batches.size();
  if (stops) batches.resize(options.max_batches);
  const auto commit = [&](BatchPart&& part) {
    checkpoint.commit(part);
    phases += part.phases;
    committed += part.slice_index.size();
    progress.advance(part.slice_index.size());
  };
  if (options.farm) {
    BatchFitter fitter(source, used, engine, device_names);
    options.farm->run(batches, used.map, [&](const std::vector<SliceRef>& b) { return fitter.fit(b); }, commit);
  } else {
    BatchLanes(source, used, devices, options.engine, device_names, options.lanes).run(batches, commit);
  }
  if (stops) {
    SweepSummary partial;
    partial.complete = false;
    partial.resumed = resumed;
    partial.slices = committed;
    partial.devices = device_names;
    partial.phases = phases;
    log_line("fit " + table_path + ": stopped after " + std::to_string(options.max_batches) + " batch(es); rerun to resume");
    return partial;
  }
  progress.finish();

  // The outputs, assembled from the committed parts in slice order, read back one at a time.
  SweepResult result = choice.whole ? std::move(*choice.whole) : empty_result(meta, used);
  if (!choice.whole) checkpoint.each_part([&](BatchPart&& part) { append_part(result, part); });
  result.mixture.fit_settings = fit_settings_json(fit);
  SweepSummary sum = write_outputs(result, table_path, meta, fit);
  checkpoint.remove();
  std::filesystem::remove(choice_path);
  sum.map = choice.text();
  sum.resumed = resumed;
  sum.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  sum.devices = device_names;
  sum.cpu_seconds = double(std::clock() - cpu_start) / CLOCKS_PER_SEC;
  sum.cores = std::max(1u, std::thread::hardware_concurrency());
  sum.phases = phases;
  for (const std::string& w : {k_cap_warning(result.mixture.k, result.mixture.l1_rel, fit.k_min, fit.k_max),
                               negative_channel_warning(reader, plan)})
    if (!w.empty()) sum.warnings.push_back(w);
  return sum;
}

}  // namespace bsdfmix
