// bsdfmix: the command line. Only this file knows about exit codes: every error
// inside is a typed exception, printed here as one line.
#include <cstdio>
#include <exception>
#include <filesystem>
#include <string>
#include <vector>

#include "cli/commands.hpp"
#include "core/error.hpp"
#include "core/file_errors.hpp"
#include "core/suggest.hpp"
#include "core/progress.hpp"
#include "device/opencl.hpp"

namespace bsdfmix::cli {

void add_common_options(CLI::App& sub, Common& common, const std::string& device_key) {
  const std::string key = device_key.empty() ? "" : device_key + ", else ";
  sub.add_option("--device", common.device,
                 "OpenCL device(s): index, name substring, cpu, gpu or all, comma-separated (default: " + key +
                     "$BSDFMIX_DEVICE, else 0)");
  sub.add_flag("-q,--quiet", common.quiet, "no progress or log lines on stderr");
}

CLI::Validator existing_file() {
  return CLI::Validator(
      [](std::string& path) {
        require_readable(path);  // throws the one wording, "PATH: no such file"
        return std::string();
      },
      "FILE", "an existing file");
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
  add_common_options(*sub, common, "the config's device:");
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

// The subcommand the command line names, deepest first (`app` itself when none), and the
// words after it.
CLI::App* named_command(CLI::App& app, int argc, char** argv, std::vector<std::string>& rest) {
  CLI::App* at = &app;
  for (int i = 1; i < argc; ++i) {
    const std::string word = argv[i];
    const auto subs = at->get_subcommands([&](CLI::App* s) { return s->get_name() == word; });
    if (!subs.empty()) {
      at = subs.front();
      rest.clear();
    } else {
      rest.push_back(word);
    }
  }
  return at;
}

// "; 'WORD': did you mean 'NAME'?" for the first of `words` close to, but not, an option
// of `command` (a word starting with -) or one of its subcommands; "" when none is.
std::string did_you_mean_hint(const CLI::App& command, const std::vector<std::string>& words) {
  for (std::string word : words) {
    std::vector<std::string> names;
    if (word.size() > 1 && word[0] == '-') {
      word = word.substr(0, word.find('='));
      for (const CLI::Option* o : command.get_options()) {
        for (const std::string& l : o->get_lnames()) names.push_back("--" + l);
        for (const std::string& n : o->get_snames()) names.push_back("-" + n);
      }
    } else {
      for (const CLI::App* sub : command.get_subcommands([](const CLI::App*) { return true; }))
        names.push_back(sub->get_name());
    }
    if (const std::string guess = closest_name(word, names); !guess.empty() && guess != word)
      return "; '" + word + "': did you mean '" + guess + "'?";
  }
  return "";
}

// The one line of a command-line error: CLI11's message, the closest known option or
// subcommand to a word it did not take, and the --help to read.
std::string usage_error(CLI::App& app, int argc, char** argv, const CLI::ParseError& e) {
  std::vector<std::string> rest;
  CLI::App* command = named_command(app, argc, argv, rest);
  std::string name = command->get_name();
  for (CLI::App* p = command->get_parent(); p; p = p->get_parent())
    name = (p->get_parent() ? p->get_name() : std::string("bsdfmix")) + " " + name;
  return one_line(e.what()) + did_you_mean_hint(*command, rest) + " (see `" + (command == &app ? "bsdfmix" : name) +
         " --help`)";
}

}  // namespace bsdfmix::cli

int main(int argc, char** argv) {
  using namespace bsdfmix;
  CLI::App app{"bsdfmix " BSDFMIX_VERSION
               ": compress tabulated appearance functions into per-slice 2D Gaussian mixtures fitted by "
               "weighted EM on OpenCL devices, and importance-sample them"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "bsdfmix " BSDFMIX_VERSION);
  app.option_defaults()->always_capture_default();  // every option's --help shows its default
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
  cli::add_recommend(app, common);
  cli::add_bench(app, common);
  try {
    app.parse(argc, argv);
    return 0;
  } catch (const CLI::Success& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    // a usage error is an input error: exit 1, as every other (docs/formats.md)
    std::fprintf(stderr, "bsdfmix: error: %s\n", cli::usage_error(app, argc, argv, e).c_str());
    return 1;
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
