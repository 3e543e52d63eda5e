// `bsdfmix render CONFIG.yaml`: cloth rendered with the mixtures (docs/render.md).
#include "cli/commands.hpp"
#include "config/config.hpp"
#include "core/progress.hpp"
#include "pipeline/stages.hpp"
#include "render/render_run.hpp"

namespace bsdfmix::cli {

void add_render(CLI::App& app, Common& common) {
  static std::string file;
  static bool no_figures = false;
  auto* sub = app.add_subcommand(
      "render",
      "render fiber cloth with the table and the mixtures (Embree): the reference, every estimator at equal "
      "samples and equal time, the stand-in against the table; EXR/PFM images, render.csv, render.json, figures");
  sub->add_option("config", file, "config YAML with table, fit and render sections (docs/render.md)")->required();
  sub->add_flag("--no-figures", no_figures, "skip scripts/render_figures.py");
  add_common_options(*sub, common);
  sub->callback([&common] {
    Progress::set_enabled(!common.quiet);
    const Config config = load_config(file);
    const render::RenderSettings settings = render::render_settings(config);  // checked before any work
    const std::string dev = device_for(config, common.device);
    stage_table(config, dev);
    render::run_render(config, settings, dev, !no_figures);
  });
}

}  // namespace bsdfmix::cli
