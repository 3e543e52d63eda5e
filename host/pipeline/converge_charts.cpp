// The convergence charts: scripts/plot_convergence.py on the study's CSVs.
#include "pipeline/converge_charts.hpp"

#include <filesystem>

#include "core/error.hpp"
#include "core/progress.hpp"
#include "pipeline/scripts.hpp"

namespace bsdfmix {

std::string converge_tail_path(const ConvergeSection& c) {
  if (!c.tail_csv.empty()) return c.tail_csv;
  std::filesystem::path p(c.csv);
  return (p.parent_path() / (p.stem().string() + "_tail.csv")).string();
}

std::string converge_light_tail_path(const ConvergeSection& c) {
  if (!c.light_tail_csv.empty()) return c.light_tail_csv;
  std::filesystem::path p(c.csv);
  return (p.parent_path() / (p.stem().string() + "_light_tail.csv")).string();
}

std::string converge_light_mixture_dir(const ConvergeSection& c) {
  if (!c.light_mixture_dir.empty()) return c.light_mixture_dir;
  return (std::filesystem::path(c.csv).parent_path() / "light_mixtures").string();
}

std::string converge_mixture_path(const Config& config) {
  if (!config.converge->mixture.empty()) return config.converge->mixture;
  if (config.fit) return config.fit->output;
  throw ConfigError(config.file + ": converge.mixture: missing (name the mixture file, or add a fit section)");
}

void converge_charts(const Config& config, const std::string& dir) {
  const ConvergeSection& c = *config.converge;
  const std::string tail = converge_tail_path(c);
  for (const auto* p : {&c.csv, &tail})
    if (!std::filesystem::exists(*p)) throw Error("charts: " + *p + " not found (run the converge stage first)");
  run_script("plot_convergence.py", {"--csv", c.csv, "--tail", tail, "-o", dir});
  log_line("charts: convergence charts in " + dir +
           " (convergence_samples, convergence_time, variance_reduction, speed_accuracy; PNG and SVG)");
}

}  // namespace bsdfmix
