// The in-memory entry to the sweep: slices in, mixtures and report rows out; and the fit
// on demand that keeps them in the fit's output files.
#include "sweep/fit_slices.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <optional>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "core/format.hpp"
#include "core/output_lock.hpp"
#include "core/progress.hpp"
#include "sweep/batch_fitter.hpp"
#include "sweep/batch_lanes.hpp"
#include "sweep/map_choice.hpp"
#include "sweep/sweep.hpp"
#include "sweep/sweep_outputs.hpp"

namespace bsdfmix {

bool ReportRow::failed() const { return status.rfind("failed:", 0) == 0; }

std::size_t SweepResult::failed() const {
  return std::size_t(std::count_if(report.begin(), report.end(), [](const ReportRow& r) { return r.failed(); }));
}

SweepResult fit_slices(const SliceSource& source, const std::vector<SliceRef>& slices, const FitSettings& fit,
                       const std::vector<Device>& devices, const std::string& what, const EngineOptions& engine_options) {
  const TableMeta& meta = source.meta();
  for (std::size_t i = 0; i < slices.size(); ++i) {
    const SliceRef& r = slices[i];
    if (r.t_o >= meta.theta_o.size() || r.p_o >= meta.phi_o.size() || r.index != meta.slice_index(r.t_o, r.p_o))
      throw Error(what + ": slice " + std::to_string(r.index) + " (" + std::to_string(r.t_o) + ", " +
                  std::to_string(r.p_o) + ") is not a slice of the grid");
    if (i > 0 && !(slices[i - 1].index < r.index))
      throw Error(what + ": the slices to fit must be sorted by index, without repeats");
  }
  // fit.map auto on the hemisphere: the probe's map (sweep/map_choice.hpp); the record
  // keeps the settings as given.
  MapChoice choice = choose_map(source, slices, fit, devices, engine_options, what);
  if (choice.whole) {
    choice.whole->mixture.fit_settings = fit_settings_json(fit);
    return std::move(*choice.whole);
  }
  const FitSettings used = with_map(fit, choice.map);
  const std::vector<std::vector<SliceRef>> batches =
      split_batches(slices, batch_size(slices.size(), used, meta.cells_per_slice()));
  SweepResult result = empty_result(meta, used);
  result.mixture.fit_settings = fit_settings_json(fit);
  Progress progress(what, slices.size(), "slices");
  std::vector<BatchPart> parts;
  const auto keep = [&](BatchPart&& part) {
    progress.advance(part.slice_index.size());
    result.phases += part.phases;
    parts.push_back(std::move(part));
  };
  BatchLanes(source, used, devices, engine_options, joined_names(devices), kDefaultLanes).run(batches, keep);
  // Parts come in the order they finish; the result is in slice order.
  std::sort(parts.begin(), parts.end(),
            [](const BatchPart& a, const BatchPart& b) { return a.slice_index.front() < b.slice_index.front(); });
  for (const BatchPart& part : parts) append_part(result, part);
  progress.finish();
  return result;
}

namespace {

// A fit-settings record (fit_settings_json's text) as typed values: the settings in a
// FitSettings (paths, batch and slices left at their defaults) and the criterion it names.
struct RecordedSettings {
  FitSettings fit;
  std::string criterion;
};

std::optional<RecordedSettings> read_record(const std::string& json) {
  try {
    const YAML::Node n = YAML::Load(json);
    if (!n.IsMap()) return std::nullopt;
    RecordedSettings r;
    FitSettings& f = r.fit;
    f.k_min = n["k_min"].as<int>();
    f.k_max = n["k_max"].as<int>();
    f.seed = n["seed"].as<std::uint64_t>();
    f.restarts = n["restarts"].as<int>();
    f.final_restarts = n["final_restarts"].as<int>();
    f.iterations = n["iterations"].as<int>();
    f.final_iterations = n["final_iterations"].as<int>();
    f.tolerance = n["tolerance"].as<double>();
    f.k_penalty = n["k_penalty"].as<double>();
    f.error_target.reset();
    if (!n["error_target"].IsNull()) f.error_target = n["error_target"].as<double>();
    f.search_pool = n["search_pool"].as<int>();
    const std::optional<SearchStrategy> search = search_strategy(n["search"].as<std::string>());
    if (!search) return std::nullopt;
    f.search = *search;
    f.refine = n["refine"].as<std::string>();
    f.refine_evaluations = n["refine_evaluations"].as<int>();
    f.refine_kl = n["refine_kl"].as<double>();
    f.refine_rgb = n["refine_rgb"].as<double>();
    f.rgb_copies.reset();
    if (!n["rgb_copies"].IsNull()) f.rgb_copies = n["rgb_copies"].as<double>();
    f.map = n["map"] ? n["map"].as<std::string>() : "theta_phi";  // records before maps
    r.criterion = n["criterion"].as<std::string>();
    return r;
  } catch (const YAML::Exception&) {
    return std::nullopt;
  }
}

// A number as a record keeps it (fit_settings_json: 9 significant digits).
double as_recorded(double v) { return std::strtod(format_number(v, "%.9g").c_str(), nullptr); }

// The settings as a record of them reads back: its numbers at the record's digits.
FitSettings as_recorded(FitSettings f) {
  for (double* v : {&f.tolerance, &f.k_penalty, &f.refine_kl, &f.refine_rgb}) *v = as_recorded(*v);
  for (std::optional<double>* v : {&f.error_target, &f.rgb_copies})
    if (*v) **v = as_recorded(**v);
  return f;
}

// The mixtures of `want` ((theta_o, phi_o) of each slice, in order) out of the file at
// `path`, when it was fitted to a table of source `source` with the settings of `fit`;
// nullopt when it holds some other fit or lacks one of those slices.
std::optional<MixtureFile> kept_slices(const std::string& path, const std::string& source, const FitSettings& fit,
                                       const std::vector<std::pair<double, double>>& want) {
  MixtureFile mf = read_mixture_file(path);
  if (mf.table_source != source || !fit_settings_match(mf.fit_settings, fit)) return std::nullopt;
  std::vector<std::pair<double, double>> held;
  for (std::size_t i = 0; i < mf.slices(); ++i) held.push_back({mf.theta_o[i], mf.phi_o[i]});
  if (held == want) return mf;
  MixtureFile sub = mf.header_only();
  for (const auto& w : want) {
    const auto at = std::find(held.begin(), held.end(), w);
    if (at == held.end()) return std::nullopt;
    sub.add_slice_from(mf, std::size_t(at - held.begin()));
  }
  return sub;
}

}  // namespace

bool fit_settings_match(const std::string& recorded, const FitSettings& fit) {
  const std::optional<RecordedSettings> a = read_record(recorded);
  return a && a->criterion == kCriterion && same_result_settings(a->fit, as_recorded(fit));
}

MixtureFile fit_slices_kept(const SliceSource& source, const std::string& table_path,
                            const std::vector<SliceRef>& slices, const FitSettings& fit,
                            const std::string& device_selector, const std::string& who,
                            const EngineOptions& engine) {
  const TableMeta& meta = source.meta();
  std::vector<std::pair<double, double>> want;
  for (const SliceRef& r : slices) want.push_back({meta.theta_o[r.t_o], meta.phi_o[r.p_o]});
  const OutputLock lock(fit.output);  // a fit of the same output elsewhere fails here, at once
  if (std::filesystem::exists(fit.output))
    if (std::optional<MixtureFile> kept = kept_slices(fit.output, meta.source, fit, want)) {
      log_line(who + ": the " + std::to_string(want.size()) + " slices needed, from " + fit.output);
      return std::move(*kept);
    }
  for (const auto* out : {&fit.output, &fit.report, &fit.search_report}) prepare_output(*out, 1 << 20);
  const std::vector<Device> devices = select_devices(device_selector);
  log_line(who + ": fitting " + std::to_string(slices.size()) + " slice(s) of " + table_path + ", K in [" +
           std::to_string(fit.k_min) + ", " + std::to_string(fit.k_max) + "]");
  SweepResult result = fit_slices(source, slices, fit, devices, "fit " + table_path, engine);
  write_outputs(result, table_path, meta, fit);
  return std::move(result.mixture);
}

}  // namespace bsdfmix
