// The bad-input corpus (tests/data/bad/cases.txt) run through the bsdfmix binary: every
// malformed table, mixture, RGL file, config and command line is rejected with exit code
// 1 and exactly one stderr line "bsdfmix: error: ..." naming the file and the problem, and
// the fix where there is one (did you mean, import it with, download it again); never a crash
// (signal), a hang (timeout), a stack trace or a library's own message, and no output
// is left behind. The well-formed bases of the corpus must succeed.
// labels: badinput
#include <catch2/catch.hpp>

#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <vector>

namespace fs = std::filesystem;

namespace {

const fs::path kCorpus = fs::path(BSDFMIX_TEST_DATA) / "bad";
constexpr int kTimeoutSeconds = 60;

struct Case {
  int line = 0;
  bool ok = false;  // expect success (a well-formed base) instead of an error
  std::string command, substring;
  std::vector<std::string> outputs;
};

std::string trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t");
  if (b == std::string::npos) return "";
  const auto e = s.find_last_not_of(" \t");
  return s.substr(b, e - b + 1);
}

std::vector<std::string> split(const std::string& s, char sep) {
  std::vector<std::string> out;
  std::string cur;
  for (char c : s) {
    if (c == sep) {
      out.push_back(cur);
      cur.clear();
    } else {
      cur += c;
    }
  }
  out.push_back(cur);
  return out;
}

// The key words of a case's substring: its parts between " && ".
std::vector<std::string> key_words(const std::string& substring) {
  std::vector<std::string> out;
  std::size_t at = 0;
  for (std::size_t cut; (cut = substring.find(" && ", at)) != std::string::npos; at = cut + 4)
    out.push_back(substring.substr(at, cut - at));
  out.push_back(substring.substr(at));
  return out;
}

std::vector<Case> load_cases() {
  std::ifstream f(kCorpus / "cases.txt");
  REQUIRE(f);
  std::vector<Case> cases;
  std::string text;
  int n = 0;
  while (std::getline(f, text)) {
    ++n;
    if (trim(text).empty() || trim(text)[0] == '#') continue;
    const auto parts = split(text, '|');
    INFO("cases.txt line " << n << ": " << text);
    REQUIRE(parts.size() == 4);
    Case c;
    c.line = n;
    const std::string expect = trim(parts[0]);
    REQUIRE((expect == "ok" || expect == "error"));
    c.ok = expect == "ok";
    c.command = trim(parts[1]);
    c.substring = trim(parts[2]);
    REQUIRE(!c.command.empty());
    if (!c.ok) REQUIRE(!c.substring.empty());
    std::istringstream outs(parts[3]);
    for (std::string o; outs >> o;) c.outputs.push_back(o);
    cases.push_back(c);
  }
  return cases;
}

std::string slurp(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(f)), {});
}

struct Result {
  bool exited = false;  // normal exit (not a signal)
  int code = -1;
  std::string out, err;
  double seconds = 0;
};

// Runs `bsdfmix <command> -q` in `dir` under a timeout.
Result run_in(const fs::path& dir, const std::string& command) {
  const std::string cmd = "cd '" + dir.string() + "' && timeout -k 5 " + std::to_string(kTimeoutSeconds) + " " +
                          BSDFMIX_BINARY + " " + command + " -q >stdout.txt 2>stderr.txt";
  const auto t0 = std::chrono::steady_clock::now();
  const int status = std::system(cmd.c_str());
  Result r;
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  r.exited = status != -1 && WIFEXITED(status);
  r.code = r.exited ? WEXITSTATUS(status) : -1;
  r.out = slurp(dir / "stdout.txt");
  r.err = slurp(dir / "stderr.txt");
  return r;
}

std::size_t count_lines(const std::string& s) {
  std::size_t n = 0;
  for (char c : s) n += c == '\n';
  return n;
}

// A fresh scratch directory with bad/ -> the corpus.
fs::path scratch(int line) {
  const fs::path dir = fs::temp_directory_path() /
                       ("bsdfmix_badinput_" + std::to_string(::getpid())) / ("case_" + std::to_string(line));
  fs::remove_all(dir);
  fs::create_directories(dir);
  fs::create_directory_symlink(kCorpus, dir / "bad");
  return dir;
}

}  // namespace

TEST_CASE("the manifest lists the whole corpus", "[badinput]") {
  const auto cases = load_cases();
  CHECK(cases.size() >= 80);
  // Every file of the corpus is used: named in a case, or by a config that a case runs.
  std::string used;
  for (const auto& c : cases) used += c.command + "\n";
  for (const auto& e : fs::directory_iterator(kCorpus))
    if (e.path().extension() == ".yaml") used += slurp(e.path());
  const std::set<std::string> tooling = {"cases.txt", "README.md", "make_corpus.py"};
  for (const auto& e : fs::directory_iterator(kCorpus)) {
    const std::string name = e.path().filename().string();
    if (tooling.count(name)) continue;
    INFO(name);
    CHECK(used.find("bad/" + name) != std::string::npos);
  }
}

TEST_CASE("every bad input is rejected with one line naming file and problem", "[badinput]") {
  const auto cases = load_cases();
  const fs::path root = fs::temp_directory_path() / ("bsdfmix_badinput_" + std::to_string(::getpid()));
  double total = 0;
  for (const auto& c : cases) {
    const fs::path dir = scratch(c.line);
    const Result r = run_in(dir, c.command);
    total += r.seconds;
    INFO("cases.txt line " << c.line << ": bsdfmix " << c.command);
    INFO("exit " << r.code << (r.exited ? "" : " (killed by a signal)") << " after " << r.seconds << " s");
    INFO("stderr: " << r.err);
    INFO("stdout: " << r.out.substr(0, 2000));
    // Never a crash or a hang: `timeout` exits 124 on a timeout, 128 + N on a signal.
    REQUIRE(r.exited);
    CHECK(r.code != 124);
    CHECK(r.code < 128);
    if (c.ok) {
      CHECK(r.code == 0);
      CHECK(r.err.empty());
      for (const auto& o : c.outputs) {
        INFO("output " << o);
        CHECK(fs::exists(dir / o));
      }
    } else {
      CHECK(r.code == 1);
      CHECK(count_lines(r.err) == 1);
      CHECK(r.err.rfind("bsdfmix: error: ", 0) == 0);
      CHECK(r.err.back() == '\n');
      for (const std::string& key : key_words(c.substring)) {  // every key word, in the one line
        INFO("key words " << key);
        CHECK(r.err.find(key) != std::string::npos);
      }
      CHECK(r.out.empty());
      // No library diagnostics or traces leak through.
      for (const char* leak : {"HDF5-DIAG", "#0", "#000", "terminate called", "Sanitizer", "yaml-cpp",
                               "Aborted", "Segmentation", "what():"}) {
        INFO("leak " << leak);
        CHECK(r.err.find(leak) == std::string::npos);
      }
      for (const auto& o : c.outputs) {
        INFO("output left behind: " << o);
        CHECK_FALSE(fs::exists(dir / o));
      }
    }
    fs::remove_all(dir);
  }
  fs::remove_all(root);
  WARN(cases.size() << " cases in " << total << " s");
}
