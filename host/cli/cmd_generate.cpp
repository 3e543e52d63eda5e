// `bsdfmix generate fiber`: tabulates the fiber scattering model.
#include "cli/commands.hpp"
#include "core/error.hpp"

namespace bsdfmix::cli {

void add_generate(CLI::App& app, Common& common) {
  auto* sub = app.add_subcommand("generate", "tabulate an appearance model into a table file");
  auto* fiber = sub->add_subcommand("fiber", "the fiber BCSDF (Chiang et al. 2016)");
  add_common_options(*fiber, common);
  sub->require_subcommand(1);
  fiber->callback([] { throw UnavailableError("generate fiber is not yet available in this build"); });
}

}  // namespace bsdfmix::cli
