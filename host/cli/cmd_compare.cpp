// `bsdfmix compare MIXTURE TABLE`: the stand-in's error against the table at every slice.
#include <cstdio>
#include <memory>
#include <vector>

#include "cli/commands.hpp"
#include "compare/compare.hpp"
#include "core/atomic_file.hpp"
#include "core/domain.hpp"
#include "core/progress.hpp"

namespace bsdfmix::cli {

void add_compare(CLI::App& app, Common& common) {
  struct Args {  // the options, kept alive by the callback
    std::string mixture, table, csv;
    std::vector<double> theta_o_deg;
  };
  const auto args = std::make_shared<Args>();
  auto* sub = app.add_subcommand(
      "compare",
      "the stand-in of a mixture file against its table at every table slice, those between fitted slices "
      "included (blended as the header blends them): luminance and per-channel relative L1, RGB error, energy, "
      "albedo");
  sub->add_option("mixture", args->mixture, "mixture file (HDF5)")->required()->check(existing_file());
  sub->add_option("table", args->table, "the table it was fitted to (HDF5)")->required()->check(existing_file());
  sub->add_option("--csv", args->csv,
                  "write one row per table slice here (docs/formats.md, \"Compare\"; default: no CSV)");
  sub->add_option("--theta-o-deg", args->theta_o_deg,
                  "also print both albedos at this theta_o (degrees, any value in the domain; repeatable; default: "
                  "none): the stand-in's as a renderer sees it, the table's linear between its two nearest rows")
      ->default_str("");
  add_common_options(*sub, common);
  sub->callback([args, &common] {
    Progress::set_enabled(!common.quiet);
    if (!args->csv.empty()) prepare_output(args->csv);
    std::vector<double> theta_o;
    for (double d : args->theta_o_deg) theta_o.push_back(d * kPi / 180);
    const Comparison c = compare_stand_in(args->mixture, args->table, theta_o);
    if (!args->csv.empty()) write_text_atomic(args->csv, comparison_csv(c));
    std::printf("compare %s against %s\n%s", args->mixture.c_str(), args->table.c_str(), comparison_summary(c).c_str());
    std::fflush(stdout);
  });
}

}  // namespace bsdfmix::cli
