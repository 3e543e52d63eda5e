// The bsdfmix binary as a user meets it: help, exit codes, one-line errors.
#include <catch2/catch.hpp>

#include <sys/wait.h>

#include <array>
#include <cstdlib>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

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

}  // namespace

TEST_CASE("every command has --help and exits 0 with it", "[cli]") {
  for (const char* c : {"", "devices", "inspect", "generate", "import", "fit", "sample", "converge", "run", "bench", "catalog",
                        "render", "compare", "pack"}) {
    INFO(c);
    const Run r = run(std::string(c) + " --help");
    CHECK(r.code == 0);
    CHECK_THAT(r.out, Catch::Contains("Usage"));
  }
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
  CHECK(bad_cmd.code != 0);
  CHECK(lines(bad_cmd.err) == 1);

  const Run no_file = run("inspect nowhere.h5");
  CHECK(no_file.code == 1);
  CHECK(lines(no_file.err) == 1);
  CHECK_THAT(no_file.err, Catch::StartsWith("bsdfmix: error: nowhere.h5: cannot open"));

  const Run no_cfg = run("fit nowhere.yaml");
  CHECK(no_cfg.code == 1);
  CHECK(lines(no_cfg.err) == 1);
  CHECK_THAT(no_cfg.err, Catch::Contains("nowhere.yaml: cannot read config file"));

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
