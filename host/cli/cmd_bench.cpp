// `bsdfmix bench em`: the EM throughput benchmark.
#include "cli/commands.hpp"
#include "core/error.hpp"

namespace bsdfmix::cli {

void add_bench(CLI::App& app, Common& common) {
  auto* sub = app.add_subcommand("bench", "benchmarks");
  auto* em = sub->add_subcommand("em", "EM throughput against the CPU reference and peer libraries");
  add_common_options(*em, common);
  sub->require_subcommand(1);
  em->callback([] { throw UnavailableError("bench em is not yet available in this build"); });
}

}  // namespace bsdfmix::cli
