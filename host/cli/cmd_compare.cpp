// `bsdfmix compare MIXTURE TABLE`: the stand-in's error against the table at every slice.
#include <cstdio>

#include "cli/commands.hpp"
#include "compare/compare.hpp"
#include "core/atomic_file.hpp"
#include "core/progress.hpp"

namespace bsdfmix::cli {

void add_compare(CLI::App& app, Common& common) {
  static std::string mixture, table, csv;
  auto* sub = app.add_subcommand(
      "compare",
      "the stand-in of a mixture file against its table at every table slice, those between fitted slices "
      "included (blended as the header blends them): luminance and per-channel relative L1, RGB error, energy");
  sub->add_option("mixture", mixture, "mixture file (HDF5)")->required()->check(CLI::ExistingFile);
  sub->add_option("table", table, "the table it was fitted to (HDF5)")->required()->check(CLI::ExistingFile);
  sub->add_option("--csv", csv, "write one row per table slice here (docs/formats.md, \"Compare CSV\")");
  add_common_options(*sub, common);
  sub->callback([&common] {
    Progress::set_enabled(!common.quiet);
    if (!csv.empty()) prepare_output(csv);
    const Comparison c = compare_stand_in(mixture, table);
    if (!csv.empty()) write_text_atomic(csv, comparison_csv(c));
    std::printf("compare %s against %s\n%s", mixture.c_str(), table.c_str(), comparison_summary(c).c_str());
    std::fflush(stdout);
  });
}

}  // namespace bsdfmix::cli
