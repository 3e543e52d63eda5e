// `bsdfmix run CONFIG.yaml`: every stage the config names, in order (host/pipeline/), and
// last, when the config has a `render` section, the render (host/render/, docs/render.md).
#include <optional>

#include "cli/commands.hpp"
#include "config/config.hpp"
#include "core/progress.hpp"
#include "pipeline/stages.hpp"
#include "render/render_run.hpp"

namespace bsdfmix::cli {

void add_run(CLI::App& app, Common& common) {
  static std::string file;
  auto* sub = add_config_command(app, common, "run",
                                 "every stage the config names, in order, charts included, and the render when the "
                                 "config has a render section",
                                 file);
  sub->callback([&common] {
    Progress::set_enabled(!common.quiet);
    const Config config = load_config(file);
    std::optional<render::RenderSettings> render;
    if (config.render) render = render::render_settings(config);  // checked before any work
    run_all(config, common.device);
    if (!render) return;
    render::run_render(config, *render, device_for(config, common.device));
    render_figures(render->output, render->summary_figure);
  });
}

}  // namespace bsdfmix::cli
