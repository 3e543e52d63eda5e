// `bsdfmix catalog CATALOG.yaml`: many tables fitted as one job (docs/scale.md).
#include <memory>

#include "cli/commands.hpp"
#include "cli/environment.hpp"
#include "core/progress.hpp"
#include "scale/catalog.hpp"
#include "scale/mpi_farm.hpp"

namespace bsdfmix::cli {

void add_catalog(CLI::App& app, Common& common) {
  struct Args {  // the options, kept alive by the callback
    std::string file;
  };
  const auto args = std::make_shared<Args>();
  auto* sub = app.add_subcommand("catalog",
                                 "fit every table of a catalog (fiber presets, RGL files, table files) as one job: "
                                 "one mixture file per table and a summary CSV; shares the work under mpirun");
  sub->add_option("catalog", args->file, "catalog YAML (docs/scale.md)")->required();
  add_common_options(*sub, common, "the catalog's device:");
  sub->callback([args, &common] {
    Progress::set_enabled(!common.quiet);
    const scale::Catalog cat = scale::load_catalog(args->file);
    const std::string dev = common.device.empty() ? cat.device : common.device;
    const RunEnvironment env = run_environment();
    scale::MpiFarm mpi(env.farm);  // MPI only under mpirun: rank 0 runs the catalog, the others fit its batches
    if (mpi.worker()) {
      std::vector<scale::FarmJob> jobs;
      for (const auto& e : cat.entries) {
        const Config& c = e.config;
        const bool remade = (c.generate && c.generate->force) || (c.import && c.import->force);
        jobs.push_back({c.table, *c.fit, !remade && exists_quiet(c.table)});
      }
      return mpi.serve(jobs, dev, env.engine);
    }
    scale::run_catalog(cat, dev, mpi.active() ? &mpi : nullptr, env.engine);
  });
}

}  // namespace bsdfmix::cli
