// `bsdfmix render` end to end on a tiny scene: the outputs (render.csv with its exact
// header, render.json, the images), a reference killed by SIGKILL after its first
// checkpoint resumes to the same image an uninterrupted run makes, a second render of the
// same output directory is refused while the first holds it, and the figure script writes
// the figures and the summary figure where the config names it, and the render's fits
// (the mixtures', the guide's) run as BSDFMIX_PRECISION and BSDFMIX_POOL_LOG say.
// labels: render cli
#include <catch2/catch.hpp>

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

using namespace std::chrono_literals;
namespace fs = std::filesystem;

namespace {

fs::path temp_dir() {
  const fs::path d = fs::temp_directory_path() / "bsdfmix_render_cli_test";
  fs::create_directories(d);
  return d;
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// A config: a small silk table, K <= 4, a 16 x 16 render whose reference takes 256 passes;
// `render_extra`: more keys of the render section, indented; `estimators`: the list compared.
std::string config(const std::string& name, bool stand_in = false, const std::string& render_extra = "",
                   const std::string& estimators = "[uniform, mis_light_gmm]") {
  const fs::path d = temp_dir();
  const std::string out = (d / name).string();
  const std::string cfg = (d / (name + ".yaml")).string();
  std::ofstream f(cfg);
  f << "table: " << (d / "silk.h5").string() << "\n"
    << "generate: {preset: silk, theta_o: 18, theta_i: 30, phi_i: 60}\n"
    << "fit: {output: " << (d / (name + "_mixture.h5")).string() << ", report: " << (d / (name + "_fit.csv")).string()
    << ", search_report: " << (d / (name + "_search.csv")).string() << ", k_max: 4, restarts: 1, final_restarts: 1}\n"
    << "render:\n  output: " << out << "\n  width: 16\n  height: 16\n  spp: 4\n  reference_spp: 256\n"
    << "  reference_estimator: mis_light_gmm\n  estimators: " << estimators << "\n  stand_in: "
    << (stand_in ? "true\n  stand_in_spp: 4\n" : "false\n") << "  scene: " << BSDFMIX_SOURCE_DIR
    << "/configs/scenes/sky.yaml\n  threads: 1\n  prepass: 8\n"
    << render_extra;
  return cfg;
}

int run(const std::string& cfg) {
  const std::string cmd = std::string(BSDFMIX_BINARY) + " render -q --no-figures " + cfg + " > /dev/null 2>&1";
  return std::system(cmd.c_str());
}

// Starts `bsdfmix render cfg` and returns its pid once the reference's first checkpoint
// is in `out` (an event, not a clock); -1 if the render exited before that.
pid_t start_until_checkpoint(const std::string& cfg, const fs::path& out) {
  const pid_t pid = fork();
  if (pid == 0) {
    execl(BSDFMIX_BINARY, BSDFMIX_BINARY, "render", "-q", "--no-figures", cfg.c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  int status = 0;
  while (!fs::exists(out / "reference.partial.h5"))
    if (waitpid(pid, &status, WNOHANG) == pid) return -1;
    else std::this_thread::sleep_for(200us);
  return pid;
}

}  // namespace

TEST_CASE("bsdfmix render writes its CSV, JSON and images", "[render][cli]") {
  const std::string cfg = config("plain");
  REQUIRE(run(cfg) == 0);
  const fs::path out = temp_dir() / "plain";
  const std::string csv = slurp(out / "render.csv");
  CHECK(csv.rfind("scene,fiber,estimator,mode,spp,seconds,rays_per_second,rel_mse,image,ns_per_vertex,rel_mse_material\n", 0) == 0);
  CHECK(csv.find(",uniform,equal_spp,4,") != std::string::npos);
  CHECK(csv.find(",mis_light_gmm,equal_time,") != std::string::npos);
  CHECK(slurp(out / "render.json").find("\"slices_needed\": ") != std::string::npos);
  for (const char* f : {"reference.exr", "reference.pfm", "uniform_spp.exr", "mis_light_gmm_time.pfm"})
    CHECK(fs::exists(out / f));
  CHECK_FALSE(fs::exists(out / "reference.partial.h5"));
  CHECK_FALSE(fs::exists(out / "render.lock"));
}

TEST_CASE("a render killed during its reference resumes to the same reference", "[render][cli]") {
  const std::string whole = config("whole"), killed = config("killed");
  REQUIRE(run(whole) == 0);
  const fs::path out = temp_dir() / "killed";
  fs::remove_all(out);
  // SIGKILL as soon as the first checkpoint is on disk (an event, not a clock)
  const pid_t pid = start_until_checkpoint(killed, out);
  REQUIRE(pid > 0);
  int status = 0;
  kill(pid, SIGKILL);
  waitpid(pid, &status, 0);
  REQUIRE(WIFSIGNALED(status));
  CHECK_FALSE(fs::exists(out / "reference.pfm"));
  // the rerun resumes, and its reference is the uninterrupted run's, byte for byte
  REQUIRE(run(killed) == 0);
  CHECK(slurp(out / "reference.pfm") == slurp(temp_dir() / "whole" / "reference.pfm"));
  CHECK_FALSE(fs::exists(out / "reference.partial.h5"));
}

TEST_CASE("a second render of the same output directory is refused while the first runs", "[render][cli]") {
  const std::string cfg = config("locked");
  const fs::path out = temp_dir() / "locked";
  fs::remove_all(out);
  const pid_t pid = start_until_checkpoint(cfg, out);
  REQUIRE(pid > 0);
  int status = 0;
  const std::string err = (temp_dir() / "locked_second.err").string();
  const int rc = std::system((std::string(BSDFMIX_BINARY) + " render -q --no-figures " + cfg + " 2> " + err).c_str());
  kill(pid, SIGKILL);
  waitpid(pid, &status, 0);
  CHECK(rc != 0);
  const std::string text = slurp(err);
  INFO(text);
  CHECK(text.rfind("bsdfmix: error: ", 0) == 0);
  CHECK(text.find("render") != std::string::npos);
  CHECK(std::count(text.begin(), text.end(), '\n') == 1);
}

TEST_CASE("bsdfmix run fits every slice and renders from that file", "[render][cli]") {
  // `run` on a config with fit and render sections: the sweep of every slice first, then
  // the render, which takes the slices it needs out of the sweep's file, fitting none.
  const std::string cfg = config("run");
  const fs::path d = temp_dir(), out = d / "run", log = d / "run.log";
  fs::remove(d / "run_mixture.h5");
  const std::string cmd = std::string(BSDFMIX_BINARY) + " run " + cfg + " > /dev/null 2> " + log.string();
  REQUIRE(std::system(cmd.c_str()) == 0);
  const std::string text = slurp(log);
  INFO(text);
  CHECK(text.find("render: fitting") == std::string::npos);
  CHECK(text.find("slices needed, from " + (d / "run_mixture.h5").string()) != std::string::npos);
  CHECK(fs::exists(out / "render.csv"));
  CHECK(fs::exists(out / "render.json"));
}

TEST_CASE("bsdfmix render writes its figures and the summary where the config names it", "[render][cli]") {
  // The figure script after the render: the figures, and the one-figure summary (the
  // quickstart's out/quickstart/render/quickstart.png) at render.summary_figure.
  const std::string cfg = config("figures", true, "  summary_figure: story.png\n");
  const fs::path out = temp_dir() / "figures";
  fs::remove_all(out);
  const std::string log = (temp_dir() / "figures.log").string();
  REQUIRE(std::system((std::string(BSDFMIX_BINARY) + " render " + cfg + " > /dev/null 2> " + log).c_str()) == 0);
  INFO(slurp(log));
  for (const char* f : {"story.png", "figures/figure_sheet.png", "figures/error_vs_time.png", "figures/stand_in.png",
                        "reference.png", "stand_in.png"})
    CHECK(fs::exists(out / f));
  CHECK_FALSE(fs::exists(out / "figures" / "summary.png"));
  CHECK(slurp(log).find("the summary " + (out / "story.png").string()) != std::string::npos);
  const std::string png = slurp(out / "story.png");
  CHECK(png.size() > 10000);
  CHECK(png.rfind("\x89PNG", 0) == 0);
}

TEST_CASE("the render's fits run as the environment says", "[render][cli]") {
  // BSDFMIX_PRECISION and BSDFMIX_POOL_LOG, read once by the command, reach the engines of
  // the render's fits: the mixtures' (first run) and the guide's leaves' (second run, the
  // mixtures kept from the first).
  const std::string cfg = config("environment", false, "", "[uniform, guided]");
  const fs::path d = temp_dir(), out = d / "environment", log = d / "environment.log";
  fs::remove(d / "environment_mixture.h5");
  fs::remove_all(out);
  const std::string render = std::string(BSDFMIX_BINARY) + " render --no-figures " + cfg + " > /dev/null 2> " + log.string();

  REQUIRE(std::system(("BSDFMIX_PRECISION=fp16 " + render).c_str()) != 0);
  const std::string bad = slurp(log);
  INFO(bad);
  CHECK(std::count(bad.begin(), bad.end(), '\n') == 1);
  CHECK(bad.find("BSDFMIX_PRECISION") != std::string::npos);
  CHECK_FALSE(fs::exists(out));

  REQUIRE(std::system(("BSDFMIX_POOL_LOG=1 " + render).c_str()) == 0);
  const std::string first = slurp(log);
  INFO(first);
  CHECK(first.find("render: fitting") != std::string::npos);
  CHECK(first.find("\npool ") != std::string::npos);

  fs::remove_all(out);
  REQUIRE(std::system(("BSDFMIX_POOL_LOG=1 " + render).c_str()) == 0);
  const std::string second = slurp(log);
  INFO(second);
  CHECK(second.find("render: fitting") == std::string::npos);
  CHECK(second.find("learn the radiance") != std::string::npos);
  CHECK(second.find("\npool ") != std::string::npos);

  REQUIRE(std::system(render.c_str()) == 0);  // without the variable: no pool lines
  CHECK(slurp(log).find("\npool ") == std::string::npos);
}
