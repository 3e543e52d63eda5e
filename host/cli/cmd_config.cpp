// `bsdfmix fit|converge|run CONFIG.yaml`: the config-driven stages.
#include "cli/commands.hpp"
#include "config/config.hpp"
#include "core/error.hpp"
#include "core/progress.hpp"
#include "pipeline/stages.hpp"
#include "scale/mpi_farm.hpp"

namespace bsdfmix::cli {

namespace {

CLI::App* add_config_command(CLI::App& app, Common& common, const char* name, const char* help,
                             std::string& file) {
  auto* sub = app.add_subcommand(name, help);
  sub->add_option("config", file, "YAML config (keys: configs/defaults.yaml)")->required();
  add_common_options(*sub, common);
  return sub;
}

}  // namespace

void add_fit(CLI::App& app, Common& common) {
  static std::string file;
  static std::size_t max_batches = SIZE_MAX;
  auto* sub = add_config_command(app, common, "fit",
                                 "the fitting sweep: Gaussian-count search and final fits, writing the "
                                 "mixture file and the fit report CSV",
                                 file);
  sub->add_option("--max-batches", max_batches,
                  "commit at most this many batches, then stop (a later run resumes)");
  sub->callback([&common] {
    Progress::set_enabled(!common.quiet);
    const Config c = load_config(file);
    if (!c.fit) throw ConfigError(file + ": fit: section missing (add `fit:` to use the defaults)");
    const std::string dev = device_for(c, common.device);
    scale::MpiFarm mpi;  // MPI only under mpirun: rank 0 runs the sweep, the others fit its batches
    if (mpi.worker()) {
      const bool remade = (c.generate && c.generate->force) || (c.import && c.import->force);
      return mpi.serve({{c.table, *c.fit, !remade && exists_quiet(c.table)}}, dev);
    }
    stage_table(c, dev);
    stage_fit(c, dev, max_batches);
  });
}

void add_converge(CLI::App& app, Common& common) {
  static std::string file;
  auto* sub = add_config_command(app, common, "converge", "the Monte Carlo convergence study, writing the convergence CSV",
                                 file);
  sub->callback([&common] {
    Progress::set_enabled(!common.quiet);
    const Config c = load_config(file);
    if (!c.converge) throw ConfigError(file + ": converge: section missing");
    stage_converge(c, device_for(c, common.device));
  });
}

void add_run(CLI::App& app, Common& common) {
  static std::string file;
  auto* sub = add_config_command(app, common, "run", "every stage the config names, in order, charts included", file);
  sub->callback([&common] {
    Progress::set_enabled(!common.quiet);
    run_all(load_config(file), common.device);
  });
}

}  // namespace bsdfmix::cli
