// `bsdfmix tune`: measures the fitting kernels' shapes on the selected device(s) and records
// the fastest (bench/shape_tune.cpp).
#include <cstdio>
#include <memory>

#include "bench/shape_tune.hpp"
#include "cli/commands.hpp"
#include "cli/environment.hpp"
#include "core/error.hpp"
#include "device/shapes.hpp"

namespace bsdfmix::cli {

void add_tune(CLI::App& app, Common& common) {
  auto* sub = app.add_subcommand("tune", "measure the fitting kernels' shapes on the selected device(s) and record the fastest");
  struct Args {  // the options, kept alive by the callback
    bench::TuneOptions o;
    bool table = false;
  };
  const auto args = std::make_shared<Args>();
  sub->add_option("--k", args->o.k, "components of the timed fits")->check(CLI::Range(1, 128));
  sub->add_option("--slices", args->o.slices, "slices of the timed fits")->check(CLI::Range(1, 4096));
  sub->add_option("--grid", args->o.theta, "theta rows of a slice (phi columns: twice as many)")->check(CLI::Range(4, 1024));
  sub->add_option("--runs", args->o.runs, "timed runs per shape (the best is kept)")->check(CLI::Range(1, 100));
  sub->add_option("--out", args->o.out,
                  "shapes file to record the fastest shape in (BSDFMIX_SHAPES reads it; default: print only)");
  sub->add_flag("--table", args->table, "print the built-in shape table and exit");
  add_common_options(*sub, common);
  sub->callback([args, &common] {
    if (args->table) {
      std::printf("%s", shape_table_text().c_str());
      return;
    }
    bench::TuneOptions o = args->o;
    o.engine = run_environment().engine;
    bench::tune_shapes(o, common.device);
  });
}

}  // namespace bsdfmix::cli
