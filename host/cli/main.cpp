// bsdfmix: the command line. Only this file knows about exit codes: every error
// inside is a typed exception, printed here as one line.
#include <cstdio>
#include <exception>
#include <filesystem>
#include <string>

#include "cli/commands.hpp"
#include "core/error.hpp"
#include "core/progress.hpp"
#include "device/opencl.hpp"

namespace bsdfmix::cli {

void add_common_options(CLI::App& sub, Common& common) {
  sub.add_option("--device", common.device,
                 "OpenCL device(s): index, name substring, cpu, gpu or all, comma-separated "
                 "(default: the config's device:, else $BSDFMIX_DEVICE, else 0)");
  sub.add_flag("-q,--quiet", common.quiet, "no progress or log lines on stderr");
}

void add_grid_options(CLI::App& sub, const std::string& theta_range, std::size_t& theta_o, std::size_t& theta_i,
                      std::size_t& phi_i) {
  sub.add_option("--theta-o", theta_o, "theta_o slices over " + theta_range)->capture_default_str()
      ->check(CLI::PositiveNumber);
  sub.add_option("--theta-i", theta_i, "theta_i cells over " + theta_range)->capture_default_str()
      ->check(CLI::PositiveNumber);
  sub.add_option("--phi-i", phi_i, "phi_i cells over [-pi, pi)")->capture_default_str()->check(CLI::PositiveNumber);
}

CLI::App* add_config_command(CLI::App& app, Common& common, const char* name, const char* help, std::string& file) {
  auto* sub = app.add_subcommand(name, help);
  sub->add_option("config", file, "YAML config (keys: configs/defaults.yaml)")->required();
  add_common_options(*sub, common);
  return sub;
}

// The error line with control characters escaped: a message quotes names and values
// read from the input (a key, an attribute, a field name), and a newline in them must
// not split the one error line.
std::string one_line(const char* what) {
  std::string out;
  for (const char* p = what; *p; ++p) {
    const unsigned char c = static_cast<unsigned char>(*p);
    if (c == '\n') out += "\\n";
    else if (c == '\r') out += "\\r";
    else if (c < 0x20 || c == 0x7f) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\x%02x", c);
      out += buf;
    } else out += char(c);
  }
  return out;
}

}  // namespace bsdfmix::cli

int main(int argc, char** argv) {
  using namespace bsdfmix;
  CLI::App app{"bsdfmix " BSDFMIX_VERSION
               ": compress tabulated appearance functions into per-slice 2D Gaussian mixtures fitted by "
               "weighted EM on OpenCL devices, and importance-sample them"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "bsdfmix " BSDFMIX_VERSION);
  cli::Common common;
  cli::add_devices(app, common);
  cli::add_inspect(app, common);
  cli::add_generate(app, common);
  cli::add_import(app, common);
  cli::add_fit(app, common);
  cli::add_sample(app, common);
  cli::add_converge(app, common);
  cli::add_run(app, common);
  cli::add_catalog(app, common);
  cli::add_render(app, common);
  cli::add_compare(app, common);
  cli::add_pack(app, common);
  cli::add_standin(app, common);
  cli::add_tune(app, common);
  cli::add_bench(app, common);
  try {
    app.parse(argc, argv);
    return 0;
  } catch (const CLI::Success& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::fprintf(stderr, "bsdfmix: error: %s (see --help)\n", cli::one_line(e.what()).c_str());
    return 2;
  } catch (const Error& e) {
    std::fprintf(stderr, "bsdfmix: error: %s\n", cli::one_line(e.what()).c_str());
    return 1;
  } catch (const cl::Error& e) {
    std::fprintf(stderr, "bsdfmix: error: OpenCL call %s failed with %s\n", e.what(), cl_error_name(e.err()));
    return 1;
  } catch (const std::filesystem::filesystem_error& e) {
    // A path the file system refuses (a name too long, a component that is a file):
    // an input error naming the path, not an internal one.
    std::fprintf(stderr, "bsdfmix: error: %s: %s\n", cli::one_line(e.path1().c_str()).c_str(),
                 cli::one_line(e.code().message().c_str()).c_str());
    return 1;
  } catch (const std::bad_alloc&) {
    std::fprintf(stderr, "bsdfmix: error: out of memory\n");
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bsdfmix: internal error: %s\n", cli::one_line(e.what()).c_str());
    return 3;
  }
}
