// `bsdfmix import rgl FILE.bsdf`: tabulates a measured RGL BRDF.
#include "cli/commands.hpp"
#include "core/error.hpp"

namespace bsdfmix::cli {

void add_import(CLI::App& app, Common& common) {
  auto* sub = app.add_subcommand("import", "tabulate measured data into a table file");
  auto* rgl = sub->add_subcommand("rgl", "a measured BRDF of the RGL material database (.bsdf)");
  add_common_options(*rgl, common);
  sub->require_subcommand(1);
  rgl->callback([] { throw UnavailableError("import rgl is not yet available in this build"); });
}

}  // namespace bsdfmix::cli
