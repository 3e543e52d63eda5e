// The convergence stage: the Monte Carlo study of the estimators (docs/sampling.md).
#include <filesystem>

#include "scene/scene.hpp"
#include "converge/study.hpp"
#include "core/error.hpp"
#include "core/progress.hpp"
#include "io/table.hpp"
#include "pipeline/converge_paths.hpp"
#include "pipeline/stages.hpp"

namespace bsdfmix {

void stage_converge(const Config& config, const std::string& device_selector, const EngineOptions& engine) {
  const ConvergeSection& c = *config.converge;
  StudySpec spec;
  spec.table = config.table;
  spec.mixture = converge_mixture_path(config);
  if (!std::filesystem::exists(spec.mixture))
    throw ConfigError(config.file + ": converge: " + spec.mixture + ": no such file (run the fit stage first)");
  spec.table_label = std::filesystem::path(config.table).stem().string();
  Domain domain;
  {
    const TableReader table(config.table);
    domain = table.meta().domain;
  }
  if (c.scenes.empty()) {
    Lighting l = default_lighting(domain, 1.0);
    l.name = "constant";
    spec.scenes.push_back(l);
  }
  for (std::size_t i = 0; i < c.scenes.size(); ++i) {
    const bool inline_scene = c.scene_files[i].empty();
    const std::string where = inline_scene ? "converge.scene" + (c.scenes.size() > 1 ? "[" + std::to_string(i) + "]" : "") : "";
    spec.scenes.push_back(parse_scene(c.scenes[i], inline_scene ? config.file : c.scene_files[i], where, domain));
  }
  for (double t : c.theta_o)
    for (double p : c.phi_o) spec.directions.emplace_back(t, p);
  for (const auto& e : c.estimators) spec.estimators.push_back(parse_estimator(e, config.file + ": converge.estimators"));
  spec.runs = c.runs;
  spec.samples_max = 1;
  while (spec.samples_max * 2 <= std::uint64_t(c.samples_max)) spec.samples_max *= 2;
  if (spec.samples_max != std::uint64_t(c.samples_max))
    log_line("converge: samples_max " + std::to_string(c.samples_max) + " rounded down to " +
             std::to_string(spec.samples_max) + " (N doubles)");
  spec.seed = c.seed;
  spec.mis.uniform_fraction = c.uniform_fraction;
  spec.mis.earned = c.earned_share;
  spec.mis.light_fraction = c.light_fraction;
  spec.mis.product_fraction = c.product_fraction;
  spec.mis.product_light = c.product_light;
  spec.mis.power = c.power_heuristic;
  spec.product_auto = c.product_auto;
  spec.mis.product.max_components = std::size_t(c.product_components);
  if (config.fit) spec.light_fit = *config.fit;
  else spec.light_fit.k_max = 16;
  spec.light_cache_dir = converge_light_mixture_dir(c);
  spec.light_engine = engine;
  spec.device = device_selector;
  spec.cpu = c.cpu;
  spec.csv = c.csv;
  spec.tail_csv = converge_tail_path(c);
  // The lighting tail CSV comes with the estimators that sample by the lighting.
  for (const Estimator e : spec.estimators)
    if (uses_lighting(e)) spec.light_tail_csv = converge_light_tail_path(c);
  // is_rgl, mis_light_rgl: converge.rgl, else the file this config imports the table from
  spec.rgl = !c.rgl.empty() ? c.rgl : config.import ? config.import->rgl : std::string();
  run_study(spec);
}

}  // namespace bsdfmix
