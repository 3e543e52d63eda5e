// `bsdfmix inspect FILE.h5`: what a table or mixture file holds.
#include <cstdio>
#include <memory>

#include "cli/commands.hpp"
#include "core/progress.hpp"
#include "io/inspect.hpp"

namespace bsdfmix::cli {

void add_inspect(CLI::App& app, Common& common) {
  auto* sub = app.add_subcommand("inspect", "print what a table or mixture file holds");
  struct Args {  // the options, kept alive by the callback
    std::string file;
    bool check = false;
  };
  const auto args = std::make_shared<Args>();
  sub->add_option("file", args->file, "table or mixture file (HDF5)")->required();
  sub->add_flag("--check", args->check, "read and validate every cell of a table (NaN, Inf, negative)");
  add_common_options(*sub, common);
  sub->callback([args, &common] {
    Progress::set_enabled(!common.quiet);
    std::fputs(describe_file(args->file, args->check).c_str(), stdout);
  });
}

}  // namespace bsdfmix::cli
