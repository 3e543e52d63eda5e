// `bsdfmix converge CONFIG.yaml`: the Monte Carlo convergence study (docs/sampling.md).
#include "cli/commands.hpp"
#include "config/config.hpp"
#include "core/error.hpp"
#include "core/progress.hpp"
#include "pipeline/stages.hpp"

namespace bsdfmix::cli {

void add_converge(CLI::App& app, Common& common) {
  static std::string file;
  auto* sub = add_config_command(app, common, "converge", "the Monte Carlo convergence study, writing the convergence CSV",
                                 file);
  sub->callback([&common] {
    Progress::set_enabled(!common.quiet);
    const Config c = load_config(file);
    if (!c.converge) throw ConfigError(file + ": converge: section missing");
    stage_converge(c, device_for(c, common.device));
  });
}

}  // namespace bsdfmix::cli
