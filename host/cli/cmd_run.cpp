// `bsdfmix run CONFIG.yaml`: every stage the config names, in order (host/pipeline/).
#include "cli/commands.hpp"
#include "config/config.hpp"
#include "core/progress.hpp"
#include "pipeline/stages.hpp"

namespace bsdfmix::cli {

void add_run(CLI::App& app, Common& common) {
  static std::string file;
  auto* sub = add_config_command(app, common, "run", "every stage the config names, in order, charts included", file);
  sub->callback([&common] {
    Progress::set_enabled(!common.quiet);
    run_all(load_config(file), common.device);
  });
}

}  // namespace bsdfmix::cli
