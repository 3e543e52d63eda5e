// `bsdfmix standin TABLE --target E -o OUT`: the smallest stand-in that meets a target
// error (and a byte budget), chosen from measured candidates (host/standin/standin.hpp).
#include <cstdio>
#include <algorithm>
#include <memory>

#include "cli/commands.hpp"
#include "config/config.hpp"
#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "core/progress.hpp"
#include "fit/em.hpp"
#include "standin/standin.hpp"

namespace bsdfmix::cli {

namespace {

// The fit settings of `config` (its fit section), else configs/defaults.yaml's.
FitSettings base_fit(const std::string& config) {
  if (config.empty())
    return parse_fit(ConfigNode("configs/defaults.yaml", "fit", YAML::Load(default_config_text())["fit"]));
  const Config c = load_config(config);
  if (!c.fit) throw ConfigError(config + ": fit: section missing (add `fit:` to use the defaults)");
  return *c.fit;
}

}  // namespace

void add_standin(CLI::App& app, Common& common) {
  struct Args {  // the options, kept alive by the callback
    std::string table, output, work, metric = "median", config, csv;
    double target = 0;
    std::uint64_t max_bytes = 0;
    int extra_caps = 1;
    std::vector<int> k_caps{4, 6, 8, 12, 16, 24, 32}, strides{1, 2, 3, 4, 5, 6, 8, 10, 12, 16, 24, 32, 48};
  };
  const auto args = std::make_shared<Args>();
  auto* sub = app.add_subcommand(
      "standin", "the smallest stand-in meeting a target error: fits every row once per K cap, measures each "
                 "theta_o stride's subset with compare at every table slice, packs the smallest that meets it");
  sub->add_option("table", args->table, "the table (HDF5; an RGL .bsdf must be imported first)")
      ->required()->check(CLI::ExistingFile);
  sub->add_option("--target", args->target, "the error to meet, in percent (as `bsdfmix compare` reports it)")
      ->required()->check(CLI::PositiveNumber);
  sub->add_option("--metric", args->metric, "the target's statistic over the table slices")
      ->capture_default_str()->check(CLI::IsMember({"median", "p90"}));
  sub->add_option("--max-bytes", args->max_bytes, "payload bytes at most (as `pack` prints them); 0: no budget")
      ->capture_default_str();
  sub->add_option("-o,--output", args->output, "the stand-in (a ragged_f32 mixture file)")->required();
  sub->add_option("--work", args->work, "fits and candidate files, reused by a rerun (default: OUT without .h5, "
                                        "plus .standin)");
  sub->add_option("--k-caps", args->k_caps, "K caps fitted, smallest first")->capture_default_str()
      ->delimiter(',')->check(CLI::Range(1, kEmMaxK));
  sub->add_option("--extra-caps", args->extra_caps,
                  "caps fitted past the first at which every row meets the target (a larger K may let a "
                  "coarser stride meet it in fewer bytes)")->capture_default_str()->check(CLI::Range(0, 64));
  sub->add_option("--strides", args->strides, "theta_o strides tried at each cap (first and last row kept; 1 always)")
      ->capture_default_str()->delimiter(',')->check(CLI::Range(1, 100000));
  sub->add_option("--config", args->config, "take the fit settings from this config's fit section "
                                            "(default: configs/defaults.yaml's)");
  sub->add_option("--csv", args->csv, "write the candidates here (docs/formats.md, \"Stand-in candidates\"; "
                                      "default: none)");
  add_common_options(*sub, common);
  sub->callback([args, &common] {
    Progress::set_enabled(!common.quiet);
    const std::string& t = args->table;
    if (t.size() > 5 && t.compare(t.size() - 5, 5, ".bsdf") == 0)
      throw InputError(t + ": this is an RGL file: import it first with `bsdfmix import rgl " + t + " -o TABLE.h5`");
    StandinOptions o;
    o.table = t;
    o.output = args->output;
    o.work = args->work.empty() ? default_work_dir(args->output) : args->work;
    o.target = args->target / 100;
    o.p90 = args->metric == "p90";
    o.max_bytes = args->max_bytes;
    o.k_caps = args->k_caps;
    o.extra_caps = args->extra_caps;
    std::sort(o.k_caps.begin(), o.k_caps.end());
    o.strides = args->strides;
    o.fit = base_fit(args->config);
    o.device = common.device;
    prepare_output(o.output);
    if (!args->csv.empty()) prepare_output(args->csv);
    const StandinResult r = choose_stand_in(o);
    const std::string csv = candidates_csv(r);
    write_text_atomic(o.work + "/candidates.csv", csv);
    if (!args->csv.empty()) write_text_atomic(args->csv, csv);
    std::printf("standin %s: %zu candidates\n%s", t.c_str(), r.candidates.size(), candidates_table(r).c_str());
    std::fflush(stdout);
    write_stand_in(r, o.output);  // without a choice: InputError naming the closest (exit 1)
    std::printf("%s\nwrote %s\n", r.why.c_str(), o.output.c_str());
    std::fflush(stdout);
  });
}

}  // namespace bsdfmix::cli
