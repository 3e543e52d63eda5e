// `bsdfmix render CONFIG.yaml`: cloth rendered with the mixtures (docs/render.md).
#include <filesystem>
#include <memory>

#include "cli/commands.hpp"
#include "cli/environment.hpp"
#include "config/config.hpp"
#include "core/progress.hpp"
#include "core/scripts.hpp"
#include "pipeline/stages.hpp"
#include "render/render_run.hpp"

namespace bsdfmix::cli {

void render_figures(const std::string& output, const std::string& summary_figure) {
  namespace fs = std::filesystem;
  const std::string summary = (fs::path(output) / summary_figure).string();
  run_script("render_figures.py", {"--dir", output, "--summary", summary});
  log_line("render: figures in " + (fs::path(output) / "figures").string() + ", the summary " + summary);
}

render::RenderInputs render_inputs(const Config& config, const std::string& device_selector,
                                   const EngineOptions& engine) {
  render::RenderInputs in;
  in.table = config.table;
  if (config.import) in.rgl = config.import->rgl;
  in.fit = *config.fit;  // render_settings checked that the config has one
  in.device_selector = device_selector;
  in.engine = engine;
  return in;
}

void add_render(CLI::App& app, Common& common) {
  struct Args {  // the options, kept alive by the callback
    std::string file;
    bool no_figures = false;
  };
  const auto args = std::make_shared<Args>();
  auto* sub = app.add_subcommand(
      "render",
      "render a scene of cloth or spheres (docs/render.md) with the table and the mixtures (Embree): the reference, "
      "every estimator at equal samples and equal time, the stand-in against the table; EXR/PFM images, render.csv, "
      "render.json, figures");
  sub->add_option("config", args->file, "config YAML with table, fit and render sections (docs/render.md)")->required();
  sub->add_flag("--no-figures", args->no_figures, "skip scripts/render_figures.py");
  add_common_options(*sub, common, "the config's device:");
  sub->callback([args, &common] {
    Progress::set_enabled(!common.quiet);
    const RunEnvironment env = run_environment();
    const Config config = load_config(args->file);
    const render::RenderSettings settings = render::render_settings(config);  // checked before any work
    const std::string dev = device_for(config, common.device);
    stage_table(config, dev);
    render::run_render(settings, render_inputs(config, dev, env.engine));
    if (!args->no_figures) render_figures(settings.output, settings.summary_figure);
  });
}

}  // namespace bsdfmix::cli
