// The charts stage: charts of what the fit and convergence stages wrote.
#include <algorithm>
#include <cmath>
#include <filesystem>

#include "core/error.hpp"
#include "core/progress.hpp"
#include "core/scripts.hpp"
#include "io/mixture_file.hpp"
#include "io/table.hpp"
#include "pipeline/converge_paths.hpp"
#include "pipeline/stages.hpp"
#include "sweep/k_timing.hpp"

namespace bsdfmix {

namespace {

struct FittedSlice {
  std::size_t slice;  // table slice index
  int k;
};

// The slices of the fit stage's mixture file with their K: each slice's table index
// is found from its (theta_o, phi_o) on the table's grid.
std::vector<FittedSlice> fitted_slices(const std::string& mixture, const TableMeta& meta) {
  const MixtureFile m = read_mixture_file(mixture);
  std::vector<FittedSlice> slices;
  for (std::size_t s = 0; s < m.slices(); ++s)
    slices.push_back({meta.slice_index(nearest_center(meta.theta_o, m.theta_o[s]), nearest_center(meta.phi_o, m.phi_o[s])), m.k[s]});
  return slices;
}

void fit_charts(const Config& config, const std::string& device_selector, const EngineOptions& engine,
                const std::string& dir) {
  const FitSection& fit = *config.fit;
  for (const auto* p : {&fit.output, &fit.report})
    if (!std::filesystem::exists(*p)) throw Error("charts: " + *p + " not found (run the fit stage first)");
  auto rows = fitted_slices(fit.output, TableReader(config.table).meta());
  if (rows.empty()) return;
  std::sort(rows.begin(), rows.end(),
            [](const FittedSlice& a, const FittedSlice& b) { return a.k < b.k || (a.k == b.k && a.slice < b.slice); });
  // Three slice types: the sharpest (most Gaussians), a median one, the broadest.
  std::vector<std::size_t> picks = {rows.back().slice, rows[rows.size() / 2].slice, rows.front().slice};
  std::vector<std::string> types = {"sharp", "medium", "broad"};
  for (std::size_t i = picks.size(); i-- > 1;)
    if (std::find(picks.begin(), picks.begin() + long(i), picks[i]) != picks.begin() + long(i)) {
      picks.erase(picks.begin() + long(i));
      types.erase(types.begin() + long(i));
    }
  const std::string timing = dir + "/k_timing.csv";
  write_k_timing_csv(timing, time_k(config.table, fit, device_selector, picks, types, engine));
  run_script("plot_fit.py", {"--table", config.table, "--mixture", fit.output, "--report", fit.report, "--search",
                             fit.search_report, "--timing", timing, "-o", dir});
  log_line("charts: fit charts in " + dir + " (fit_speed_accuracy, fit_chosen_k, fit_slices; PNG and SVG)");
}

// Charts of the convergence CSV (scripts/plot_convergence.py) into `dir`.
void converge_charts(const Config& config, const std::string& dir) {
  const ConvergeSection& c = *config.converge;
  const std::string tail = converge_tail_path(c);
  for (const auto* p : {&c.csv, &tail})
    if (!std::filesystem::exists(*p)) throw Error("charts: " + *p + " not found (run the converge stage first)");
  run_script("plot_convergence.py", {"--csv", c.csv, "--tail", tail, "-o", dir});
  log_line("charts: convergence charts in " + dir +
           " (convergence_samples, convergence_time, variance_reduction, speed_accuracy; PNG and SVG)");
}

}  // namespace

void stage_charts(const Config& config, const std::string& device_selector, const EngineOptions& engine) {
  const std::string dir = config.charts->dir;
  std::filesystem::create_directories(dir);
  if (config.fit) fit_charts(config, device_selector, engine, dir);
  if (config.converge) converge_charts(config, dir);
}

}  // namespace bsdfmix
