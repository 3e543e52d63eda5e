// `bsdfmix fit CONFIG.yaml`: the fitting sweep (docs/fitting.md), shared under mpirun.
#include <memory>

#include "cli/commands.hpp"
#include "cli/environment.hpp"
#include "config/config.hpp"
#include "core/error.hpp"
#include "core/progress.hpp"
#include "pipeline/stages.hpp"
#include "scale/mpi_farm.hpp"

namespace bsdfmix::cli {

void add_fit(CLI::App& app, Common& common) {
  struct Args {  // the options, kept alive by the callback
    std::string file;
    std::size_t max_batches = SIZE_MAX;
    unsigned lanes = kDefaultLanes;
  };
  const auto args = std::make_shared<Args>();
  auto* sub = add_config_command(app, common, "fit",
                                 "the fitting sweep: Gaussian-count search and final fits, writing the "
                                 "mixture file and the fit report CSV",
                                 args->file);
  sub->add_option("--max-batches", args->max_batches,
                  "commit at most this many batches, then stop (a later run resumes; default: no limit)")
      ->default_str("");
  sub->add_option("--lanes", args->lanes,
                  "batches fitted side by side, each with its own engine on the same devices: two keep "
                  "the cores busy through a batch's host steps; 1 fits one batch at a time. The "
                  "mixtures do not depend on it")
      ->check(CLI::Range(1u, 16u))
      ->capture_default_str();
  sub->callback([args, &common] {
    Progress::set_enabled(!common.quiet);
    const RunEnvironment env = run_environment();
    const Config c = load_config(args->file);
    if (!c.fit) throw ConfigError(args->file + ": fit: section missing (add `fit:` to use the defaults)");
    const std::string dev = device_for(c, common.device);
    scale::MpiFarm mpi(env.farm);  // MPI only under mpirun: rank 0 runs the sweep, the others fit its batches
    if (mpi.worker()) {
      const bool remade = (c.generate && c.generate->force) || (c.import && c.import->force);
      return mpi.serve({{c.table, *c.fit, !remade && exists_quiet(c.table)}}, dev, env.engine);
    }
    stage_table(c, dev);
    stage_fit(c, dev, SweepOptions{args->max_batches, mpi.batch_farm(), env.engine, args->lanes});
  });
}

}  // namespace bsdfmix::cli
