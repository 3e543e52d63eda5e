// The subcommands of the bsdfmix CLI; each file host/cli/cmd_<name>.cpp adds one.
#pragma once

#include <CLI/CLI.hpp>

#include <cstddef>
#include <string>

namespace bsdfmix {
struct Config;
struct EngineOptions;
namespace render {
struct RenderInputs;
}
}  // namespace bsdfmix

namespace bsdfmix::cli {

// Options every subcommand shares.
struct Common {
  std::string device;  // --device: index, name substring, cpu/gpu, all
  bool quiet = false;  // --quiet: no progress or log lines
};

void add_devices(CLI::App& app, Common& common);
void add_inspect(CLI::App& app, Common& common);
void add_generate(CLI::App& app, Common& common);
void add_import(CLI::App& app, Common& common);
void add_fit(CLI::App& app, Common& common);
void add_sample(CLI::App& app, Common& common);
void add_converge(CLI::App& app, Common& common);
void add_run(CLI::App& app, Common& common);
void add_bench(CLI::App& app, Common& common);
void add_catalog(CLI::App& app, Common& common);
void add_render(CLI::App& app, Common& common);
void add_compare(CLI::App& app, Common& common);
void add_pack(CLI::App& app, Common& common);
void add_tune(CLI::App& app, Common& common);
void add_recommend(CLI::App& app, Common& common);
void add_standin(CLI::App& app, Common& common);

// The render's figures and summary figure (scripts/render_figures.py) over the outputs
// of a render into `output` (cmd_render.cpp).
void render_figures(const std::string& output, const std::string& summary_figure);

// What the render of `config` reads besides its render settings (checked first by
// render::render_settings): the config's table, RGL file and fit settings, the device
// selector in force and the engine options (cmd_render.cpp).
render::RenderInputs render_inputs(const Config& config, const std::string& device_selector,
                                   const EngineOptions& engine);

// Adds --device and --quiet to a subcommand; `device_key` names the input key that
// selects the device before $BSDFMIX_DEVICE ("the config's device:"), "" for none.
void add_common_options(CLI::App& sub, Common& common, const std::string& device_key = "");

// A validator of an input file argument: a missing one is an InputError, "PATH: no such file".
CLI::Validator existing_file();

// The table grid's --theta-o, --theta-i (both over theta_range) and --phi-i of a
// subcommand that tabulates.
void add_grid_options(CLI::App& sub, const std::string& theta_range, std::size_t& theta_o, std::size_t& theta_i,
                      std::size_t& phi_i);

// A subcommand of one required CONFIG.yaml argument (stored in `file`), with the common options.
CLI::App* add_config_command(CLI::App& app, Common& common, const char* name, const char* help, std::string& file);

}  // namespace bsdfmix::cli
