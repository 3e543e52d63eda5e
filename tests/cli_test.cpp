// The bsdfmix binary as a user meets it: help, exit codes, one-line errors.
#include <catch2/catch.hpp>

#include <sys/wait.h>

#include <algorithm>
#include <array>
#include <cstdlib>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "io/table.hpp"

namespace fs = std::filesystem;

namespace {

struct Run {
  int code;
  std::string out, err;
};

Run run(const std::string& args) {
  const fs::path dir = fs::temp_directory_path() / "bsdfmix_cli_test";
  fs::create_directories(dir);
  const std::string out = (dir / "out.txt").string(), err = (dir / "err.txt").string();
  const std::string cmd = std::string(BSDFMIX_BINARY) + " " + args + " >" + out + " 2>" + err;
  const int status = std::system(cmd.c_str());
  auto slurp = [](const std::string& p) {
    std::ifstream f(p);
    return std::string((std::istreambuf_iterator<char>(f)), {});
  };
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, slurp(out), slurp(err)};
}

std::size_t lines(const std::string& s) {
  std::size_t n = 0;
  for (char c : s) n += c == '\n';
  return n;
}

// The lines of section `title` ("Options:", "Positionals:", "Subcommands:") of a --help
// text, each with its wrapped description joined to it.
std::vector<std::string> help_section(const std::string& help, const std::string& title) {
  std::vector<std::string> out;
  std::istringstream in(help);
  bool inside = false;
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] != ' ') {
      inside = line == title;
      continue;
    }
    if (!inside) continue;
    const std::size_t indent = line.find_first_not_of(' ');
    if (indent >= 20 && !out.empty()) out.back() += "  " + line.substr(indent);  // a wrapped description
    else out.push_back(line);
  }
  return out;
}

// The option part of a help line (before the first run of two spaces) and its words.
std::vector<std::string> option_words(const std::string& line) {
  const std::size_t b = line.find_first_not_of(' ');
  const std::string part = line.substr(b, line.find("  ", b) == std::string::npos ? std::string::npos
                                                                                    : line.find("  ", b) - b);
  std::istringstream in(part);
  std::vector<std::string> words;
  for (std::string w; in >> w;) words.push_back(w);
  return words;
}

// Every command and subcommand, as `bsdfmix --help` and theirs list them.
std::vector<std::string> commands(const std::string& prefix) {
  std::vector<std::string> out{prefix};
  for (const std::string& line : help_section(run(prefix + " --help").out, "Subcommands:")) {
    const std::vector<std::string> words = option_words(line);
    if (words.empty()) continue;
    for (const std::string& c : commands(prefix.empty() ? words[0] : prefix + " " + words[0])) out.push_back(c);
  }
  return out;
}

}  // namespace

TEST_CASE("every command's --help shows defaults, choices and required flags", "[cli]") {
  const std::vector<std::string> all = commands("");
  CHECK(all.size() >= 17);  // discovered, so that a new command is walked too
  for (const std::string& c : all) {
    INFO("bsdfmix " << c << " --help");
    const Run r = run(c + " --help");
    CHECK(r.code == 0);
    CHECK_THAT(r.out, Catch::Contains("Usage"));
    bool config = false;
    for (const std::string& line : help_section(r.out, "Positionals:"))
      config = config || option_words(line).front() == "config" || option_words(line).front() == "catalog";
    for (const std::string& line : help_section(r.out, "Options:")) {
      INFO(line);
      const std::vector<std::string> words = option_words(line);
      const std::string desc = line.substr(line.find(words.back()) + words.back().size());
      const bool flag = words.size() == 1;
      const bool shown = line.find('=') != std::string::npos || desc.find("default") != std::string::npos ||
                         std::find(words.begin(), words.end(), "REQUIRED") != words.end();
      CHECK((flag || shown));  // a value option says its default, or that it is required
      CHECK(words.front().find('{') == std::string::npos);  // no "{false}" beside a flag
      for (const char* choice : {"--storage", "--interpolation", "--negative", "--precision"})
        if (words.front() == choice) CHECK((words.size() > 1 && words[1].find(":{") != std::string::npos));
      const bool says_config = line.find("'s device:") != std::string::npos;  // the config's or the catalog's
      if (words.front() == "--device") CHECK(says_config == config);
    }
  }
  CHECK_THAT(run("render --help").out, Catch::Contains("cloth or spheres"));
  const std::string sampling = run("bench sampling --help").out;
  for (const char* required : {"--mixture FILE REQUIRED", "--table FILE REQUIRED", "--csv TEXT REQUIRED"})
    CHECK_THAT(sampling, Catch::Contains(required));
}

TEST_CASE("devices lists the OpenCL device with its index", "[cli]") {
  const Run r = run("devices --check");
  CHECK(r.code == 0);
  CHECK_THAT(r.out, Catch::Contains("[0]"));
  CHECK_THAT(r.out, Catch::Contains("compute units"));
  CHECK_THAT(r.out, Catch::Contains("self-test [0]"));
  CHECK_THAT(r.out, Catch::Contains(": ok"));
}

TEST_CASE("errors are one line on stderr with a non-zero exit", "[cli]") {
  const Run bad_cmd = run("frobnicate");
  CHECK(bad_cmd.code == 1);  // a usage error exits 1, as every input error
  CHECK(lines(bad_cmd.err) == 1);

  const Run no_file = run("inspect nowhere.h5");
  CHECK(no_file.code == 1);
  CHECK(lines(no_file.err) == 1);
  CHECK_THAT(no_file.err, Catch::StartsWith("bsdfmix: error: nowhere.h5: no such file"));

  const Run no_cfg = run("fit nowhere.yaml");
  CHECK(no_cfg.code == 1);
  CHECK(lines(no_cfg.err) == 1);
  CHECK_THAT(no_cfg.err, Catch::Contains("nowhere.yaml: no such file"));

  setenv("BSDFMIX_PRECISION", "fp16", 1);  // read once, at the edge, before the config
  const Run bad_env = run("fit nowhere.yaml");
  unsetenv("BSDFMIX_PRECISION");
  CHECK(bad_env.code != 0);
  CHECK(lines(bad_env.err) == 1);
  CHECK_THAT(bad_env.err, Catch::Contains("BSDFMIX_PRECISION"));
  for (const char* command : {"render", "converge", "run"}) {  // every command whose fits it tunes
    setenv("BSDFMIX_PRECISION", "fp16", 1);
    const Run bad = run(std::string(command) + " nowhere.yaml");
    unsetenv("BSDFMIX_PRECISION");
    INFO(command);
    CHECK(bad.code != 0);
    CHECK(lines(bad.err) == 1);
    CHECK_THAT(bad.err, Catch::Contains("BSDFMIX_PRECISION"));
  }

  const Run bad_dev = run("devices --check --device no-such-device-xyz");
  CHECK(bad_dev.code == 1);
  CHECK(lines(bad_dev.err) == 1);
  CHECK_THAT(bad_dev.err, Catch::Contains("no device matches"));
}

TEST_CASE("inspect describes a table", "[cli]") {
  const fs::path dir = fs::temp_directory_path() / "bsdfmix_cli_test";
  const std::string p = (dir / "t.h5").string();
  bsdfmix::TableMeta m = bsdfmix::make_grid(bsdfmix::Domain::Hemisphere, 2, 1, 4, 8, true);
  bsdfmix::write_table(p, m, std::vector<float>(64, 0.5f));
  const Run r = run("inspect --check " + p);
  CHECK(r.code == 0);
  CHECK_THAT(r.out, Catch::Contains("domain     hemisphere"));
  CHECK_THAT(r.out, Catch::Contains("[2, 1, 4, 8] float32"));
  CHECK_THAT(r.out, Catch::Contains("all valid"));
}
