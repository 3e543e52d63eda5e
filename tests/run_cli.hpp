// Runs the bsdfmix CLI from a test: its exit code, stdout and stderr, through files in a
// scratch folder of the test's own (tests that run it in parallel use different folders).
#pragma once

#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

namespace bsdfmix::test {

struct CliRun {
  int code;
  std::string out, err;
};

// `bsdfmix ARGS`, its output kept in `scratch`/out.txt and err.txt.
inline CliRun run_cli(const std::string& args, const std::filesystem::path& scratch) {
  std::filesystem::create_directories(scratch);
  const std::string out = (scratch / "out.txt").string(), err = (scratch / "err.txt").string();
  const int status = std::system((std::string(BSDFMIX_BINARY) + " " + args + " >" + out + " 2>" + err).c_str());
  auto slurp = [](const std::string& p) {
    std::ifstream f(p);
    return std::string((std::istreambuf_iterator<char>(f)), {});
  };
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, slurp(out), slurp(err)};
}

}  // namespace bsdfmix::test
