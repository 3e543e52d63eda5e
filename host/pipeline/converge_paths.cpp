// The defaults of the convergence study's output paths.
#include "pipeline/converge_paths.hpp"

#include <filesystem>

#include "core/error.hpp"

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

}  // namespace bsdfmix
