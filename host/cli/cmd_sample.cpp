// `bsdfmix sample M.h5`: importance samples from a mixture file.
#include "cli/commands.hpp"
#include "core/error.hpp"

namespace bsdfmix::cli {

void add_sample(CLI::App& app, Common& common) {
  auto* sub = app.add_subcommand("sample", "draw samples from a mixture file: theta,phi,pdf_omega,valid");
  add_common_options(*sub, common);
  sub->callback([] { throw UnavailableError("sample is not yet available in this build"); });
}

}  // namespace bsdfmix::cli
