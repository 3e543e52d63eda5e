// `bsdfmix generate fiber`: tabulates the fiber scattering model.
#include <chrono>
#include <cstdio>
#include <memory>

#include "cli/commands.hpp"
#include "core/error.hpp"
#include "core/progress.hpp"
#include "tables/fiber_generator.hpp"
#include "tables/fiber_presets.hpp"

namespace bsdfmix::cli {

void add_generate(CLI::App& app, Common& common) {
  auto* sub = app.add_subcommand("generate", "tabulate an appearance model into a table file");
  auto* fiber = sub->add_subcommand(
      "fiber", "the fiber BCSDF of Chiang et al. 2016 (R, TT, TRT and residual lobes), fiber domain; "
               "presets: " + fiber_preset_names());
  struct Args {  // the options, kept alive by the callback
    FiberGenerateOptions opt;
    std::string output;
    bool no_symmetry = false;
  };
  const auto args = std::make_shared<Args>();
  fiber->add_option("--preset", args->opt.preset, "model parameters: " + fiber_preset_names())->required();
  add_grid_options(*fiber, "[-pi/2, pi/2]", args->opt.n_theta_o, args->opt.n_theta_i, args->opt.n_phi_i);
  fiber->add_flag("--no-symmetry", args->no_symmetry,
                  "tabulate every (theta_o, phi_o) slice instead of one phi_o (azimuthal symmetry)");
  fiber->add_option("--phi-o", args->opt.n_phi_o, "phi_o slices over [-pi, pi) with --no-symmetry (default: --phi-i)")
      ->check(CLI::PositiveNumber);
  fiber->add_option("--noise", args->opt.noise,
                    "simulated measurement noise: multiplicative log-normal, LEVEL = sigma of log f (0: none)")
      ->capture_default_str();
  fiber->add_option("--seed", args->opt.seed, "noise seed")->capture_default_str();
  fiber->add_option("--h-nodes", args->opt.h_nodes, "Gauss-Legendre nodes in the fiber offset h")
      ->capture_default_str();
  fiber->add_option("--deflate", args->opt.deflate,
                    "compress the file: 0 none, 1..9 HDF5 shuffle + deflate at that level (slower to write)")
      ->capture_default_str();
  fiber->add_option("-o,--output", args->output, "the table file to write (HDF5)")->required();
  add_common_options(*fiber, common);
  sub->require_subcommand(1);
  fiber->callback([args, fiber, &common] {
    Progress::set_enabled(!common.quiet);
    args->opt.symmetry = !args->no_symmetry;
    if (args->opt.symmetry && fiber->count("--phi-o") > 0 && args->opt.n_phi_o != 1)
      throw ConfigError("generate fiber: --phi-o needs --no-symmetry");
    if (!args->opt.symmetry && fiber->count("--phi-o") > 0 && args->opt.n_phi_o < 2)
      throw ConfigError("generate fiber: --no-symmetry needs --phi-o 2 or more (one column is symmetry)");
    if (args->opt.symmetry) args->opt.n_phi_o = 1;
    const auto start = std::chrono::steady_clock::now();
    generate_fiber_table(args->opt, common.device, args->output);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    char buf[64];
    std::snprintf(buf, sizeof buf, " in %.2f s", seconds);
    log_line("wrote " + args->output + buf);
  });
}

}  // namespace bsdfmix::cli
