// `bsdfmix recommend MIXTURE TABLE`: the sampler to take for a material, by a short
// measurement of the candidates (bench/sampler_choice.hpp, docs/sampling.md).
#include <cstdio>
#include <filesystem>
#include <memory>

#include "bench/sampler_choice.hpp"
#include "cli/commands.hpp"
#include "core/atomic_file.hpp"
#include "core/progress.hpp"
#include "io/table.hpp"

namespace bsdfmix::cli {

void add_recommend(CLI::App& app, Common& common) {
  struct Args {  // the options, kept alive by the callback
    bench::SamplerChoiceOptions o;
    std::string csv;
  };
  const auto args = std::make_shared<Args>();
  auto* sub = app.add_subcommand(
      "recommend",
      "the sampler to take for a material, measured in seconds: each candidate's variance at a few view "
      "elevations, BSDF only and, with --scene, with lighting (docs/sampling.md, \"Choosing a sampler\")");
  sub->add_option("mixture", args->o.mixture, "mixture file (HDF5)")->required()->check(existing_file());
  sub->add_option("table", args->o.table, "the table it was fitted to (HDF5)")->required()->check(existing_file());
  sub->add_option("--rgl", args->o.rgl, "the RGL file the table came from: f is the file, its own sampler a candidate "
                  "(default: none)")
      ->check(existing_file());
  sub->add_option("--scene", args->o.scene, "a scene file (configs/scenes/): the candidates with its lighting too "
                  "(default: none, BSDF only)")
      ->check(existing_file());
  sub->add_option("--views", args->o.views, "view elevations, cell centers of [0, --theta-max]")->capture_default_str();
  sub->add_option("--theta-max", args->o.theta_max_deg, "largest view elevation (degrees)")->capture_default_str();
  sub->add_option("--samples", args->o.samples, "samples per candidate and view")->capture_default_str();
  sub->add_option("--seed", args->o.seed, "seed of the samples")->capture_default_str();
  sub->add_option("--light-fraction", args->o.light_fraction, "light sampling's share in the mis_light_* candidates")
      ->capture_default_str();
  sub->add_option("-o,--csv", args->csv, "write one row per candidate here (docs/formats.md, \"Recommend\"; "
                  "default: none)");
  add_common_options(*sub, common);
  sub->callback([args, &common] {
    Progress::set_enabled(!common.quiet);
    if (!args->csv.empty()) prepare_output(args->csv);
    if (args->o.rgl.empty() && TableReader(args->o.table).meta().source.find("\"model\": \"rgl\"") != std::string::npos)
      log_line(args->o.table + ": imported from an RGL file: give it with --rgl to measure against the file and its sampler");
    const bench::SamplerChoice c = bench::choose_sampler(args->o);
    const std::string material =
        std::filesystem::path(args->o.rgl.empty() ? args->o.table : args->o.rgl).stem().string();
    if (!args->csv.empty()) write_text_atomic(args->csv, bench::sampler_choice_csv(c, material));
    std::printf("%s", bench::sampler_choice_text(c, material).c_str());
    std::fflush(stdout);
  });
}

}  // namespace bsdfmix::cli
