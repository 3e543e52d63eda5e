// `bsdfmix inspect FILE.h5`: what a table or mixture file holds.
#include <cstdio>

#include "cli/commands.hpp"
#include "core/progress.hpp"
#include "io/inspect.hpp"

namespace bsdfmix::cli {

void add_inspect(CLI::App& app, Common& common) {
  auto* sub = app.add_subcommand("inspect", "print what a table or mixture file holds");
  static std::string file;
  static bool check = false;
  sub->add_option("file", file, "table or mixture file (HDF5)")->required();
  sub->add_flag("--check", check, "read and validate every cell of a table (NaN, Inf, negative)");
  add_common_options(*sub, common);
  sub->callback([&common] {
    Progress::set_enabled(!common.quiet);
    std::fputs(describe_file(file, check).c_str(), stdout);
  });
}

}  // namespace bsdfmix::cli
