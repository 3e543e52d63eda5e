// The charts stage: charts of what the fit and convergence stages wrote.
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "core/error.hpp"
#include "core/progress.hpp"
#include "pipeline/converge_paths.hpp"
#include "core/scripts.hpp"
#include "pipeline/stages.hpp"
#include "sweep/k_timing.hpp"

namespace bsdfmix {

namespace {

struct ReportRow {
  std::size_t slice;
  int k;
};

std::vector<ReportRow> read_report(const std::string& path) {
  std::ifstream f(path);
  if (!f) throw Error("charts: cannot read fit report " + path);
  std::vector<ReportRow> rows;
  std::string line;
  std::getline(f, line);  // header
  while (std::getline(f, line)) {
    std::istringstream s(line);
    std::string slice, theta, phi, k;
    std::getline(s, slice, ',');
    std::getline(s, theta, ',');
    std::getline(s, phi, ',');
    std::getline(s, k, ',');
    if (!slice.empty()) rows.push_back({std::stoul(slice), std::stoi(k)});
  }
  return rows;
}

void fit_charts(const Config& config, const std::string& device_selector, const std::string& dir) {
  const FitSection& fit = *config.fit;
  for (const auto* p : {&fit.output, &fit.report})
    if (!std::filesystem::exists(*p)) throw Error("charts: " + *p + " not found (run the fit stage first)");
  auto rows = read_report(fit.report);
  if (rows.empty()) return;
  std::sort(rows.begin(), rows.end(), [](const ReportRow& a, const ReportRow& b) { return a.k < b.k || (a.k == b.k && a.slice < b.slice); });
  // Three slice types: the sharpest (most Gaussians), a median one, the broadest.
  std::vector<std::size_t> picks = {rows.back().slice, rows[rows.size() / 2].slice, rows.front().slice};
  std::vector<std::string> types = {"sharp", "medium", "broad"};
  for (std::size_t i = picks.size(); i-- > 1;)
    if (std::find(picks.begin(), picks.begin() + long(i), picks[i]) != picks.begin() + long(i)) {
      picks.erase(picks.begin() + long(i));
      types.erase(types.begin() + long(i));
    }
  const std::string timing = dir + "/k_timing.csv";
  write_k_timing_csv(timing, time_k(config.table, fit, device_selector, picks, types));
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

void stage_charts(const Config& config, const std::string& device_selector) {
  const std::string dir = config.charts->dir;
  std::filesystem::create_directories(dir);
  if (config.fit) fit_charts(config, device_selector, dir);
  if (config.converge) converge_charts(config, dir);
}

}  // namespace bsdfmix
