// `bsdfmix run CONFIG.yaml`: every stage the config names, in order (host/pipeline/), and
// last, when the config has a `render` section, the render (host/render/, docs/render.md).
#include <memory>
#include <optional>

#include "cli/commands.hpp"
#include "cli/environment.hpp"
#include "config/config.hpp"
#include "core/progress.hpp"
#include "pipeline/stages.hpp"
#include "render/render_run.hpp"

namespace bsdfmix::cli {

void add_run(CLI::App& app, Common& common) {
  struct Args {  // the options, kept alive by the callback
    std::string file;
  };
  const auto args = std::make_shared<Args>();
  auto* sub = add_config_command(app, common, "run",
                                 "every stage the config names, in order, charts included, and the render when the "
                                 "config has a render section",
                                 args->file);
  sub->callback([args, &common] {
    Progress::set_enabled(!common.quiet);
    const RunEnvironment env = run_environment();
    const Config config = load_config(args->file);
    std::optional<render::RenderSettings> render;
    if (config.render) render = render::render_settings(config);  // checked before any work
    run_all(config, common.device, env.engine);
    if (!render) return;
    render::run_render(*render, render_inputs(config, device_for(config, common.device), env.engine));
    render_figures(render->output, render->summary_figure);
  });
}

}  // namespace bsdfmix::cli
