// `bsdfmix converge CONFIG.yaml`: the Monte Carlo convergence study (docs/sampling.md).
#include <memory>

#include "cli/commands.hpp"
#include "cli/environment.hpp"
#include "config/config.hpp"
#include "core/error.hpp"
#include "core/progress.hpp"
#include "pipeline/stages.hpp"

namespace bsdfmix::cli {

void add_converge(CLI::App& app, Common& common) {
  struct Args {  // the options, kept alive by the callback
    std::string file;
  };
  const auto args = std::make_shared<Args>();
  auto* sub = add_config_command(app, common, "converge", "the Monte Carlo convergence study, writing the convergence CSV",
                                 args->file);
  sub->callback([args, &common] {
    Progress::set_enabled(!common.quiet);
    const RunEnvironment env = run_environment();
    const Config c = load_config(args->file);
    if (!c.converge) throw ConfigError(args->file + ": converge: section missing");
    stage_converge(c, device_for(c, common.device), env.engine);
  });
}

}  // namespace bsdfmix::cli
