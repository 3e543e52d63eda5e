// The fitting sweep: the Gaussian-count criterion, scene-driven slice plans, the outputs,
// and crash safety (an interrupted sweep resumes to the same result; kill -9 leaves no
// half-written file).
// labels: fit
#include <catch2/catch.hpp>

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <thread>

#include "config/config.hpp"
#include "core/error.hpp"
#include "core/progress.hpp"
#include "io/mixture_file.hpp"
#include "io/table.hpp"
#include "sweep/criterion.hpp"
#include "sweep/fit_error.hpp"
#include "sweep/slice_plan.hpp"
#include "sweep/sweep.hpp"

using namespace bsdfmix;
namespace fs = std::filesystem;

namespace {

fs::path temp_dir() {
  const fs::path d = fs::temp_directory_path() / "bsdfmix_sweep_test";
  fs::create_directories(d);
  return d;
}

struct Lobe {
  double w, mt, mp, stt, stp, spp;
};

// A fiber table whose slice t is f such that the integrand weights are the mixture
// of `lobes(t)` (f = density / cos(theta)).
template <class Lobes>
std::string mixture_table(const std::string& name, std::size_t n_theta_o, std::size_t nt, std::size_t np, Lobes lobes) {
  TableMeta m = make_grid(Domain::Fiber, n_theta_o, 1, nt, np, true);
  m.source = R"({"model": "test mixture"})";
  std::vector<float> v;
  for (std::size_t t = 0; t < n_theta_o; ++t) {
    std::vector<double> w, mean, cov;
    for (const Lobe& l : lobes(t)) {
      w.push_back(l.w);
      mean.insert(mean.end(), {l.mt, l.mp});
      cov.insert(cov.end(), {l.stt, l.stp, l.spp});
    }
    if (w.empty()) {  // an all-zero slice
      v.insert(v.end(), nt * np, 0.0f);
      continue;
    }
    const mix::SliceMixture mixture = make_slice_mixture(w, mean, cov);
    for (std::size_t i = 0; i < nt; ++i)
      for (std::size_t j = 0; j < np; ++j)
        v.push_back(float(mixture.pdf_param(m.theta_i[i], m.phi_i[j]) / std::cos(m.theta_i[i])));
  }
  const std::string path = (temp_dir() / name).string();
  write_table(path, m, v);
  return path;
}

FitSection fit_settings(const std::string& stem) {
  FitSection f;
  f.output = (temp_dir() / (stem + "_mixture.h5")).string();
  f.report = (temp_dir() / (stem + "_fit.csv")).string();
  f.search_report = (temp_dir() / (stem + "_search.csv")).string();
  f.k_min = 1;
  f.k_max = 6;
  f.restarts = 2;
  f.final_restarts = 3;
  f.iterations = 60;
  f.final_iterations = 150;
  f.tolerance = 1e-7;
  f.search_pool = 1;
  return f;
}

std::string slurp(const std::string& p) {
  std::ifstream f(p);
  return std::string((std::istreambuf_iterator<char>(f)), {});
}

}  // namespace

TEST_CASE("the L1 error integrates narrow components over their cells", "[fit][error]") {
  WeightedSlice s;
  s.theta = uniform_centers(-kPi / 2, kPi / 2, 30);
  s.phi = uniform_centers(-kPi, kPi, 60);
  s.w.assign(30 * 60, 0.0);
  s.w[12 * 60 + 40] = 1.0;  // one hot cell
  const double h = axis_step(s.theta);
  // A Gaussian a quarter cell wide on the cell: about 90% of its mass is in the cell.
  const double narrow = l1_rel_error(s, make_slice_mixture({1.0}, {s.theta[12], s.phi[40]}, {h * h / 16, 0, h * h / 16}));
  CHECK(narrow == Approx(0.17).margin(0.05));
  // A Gaussian 3 cells wide is measured by its center densities: L1 near 2 (almost all
  // of its mass lies outside the hot cell).
  const double broad = l1_rel_error(s, make_slice_mixture({1.0}, {s.theta[12], s.phi[40]}, {9 * h * h, 0, 9 * h * h}));
  CHECK(broad > 1.9);
  // A well-resolved lobe sampled at cell centers has an L1 error near 0.
  WeightedSlice lobe = s;
  const mix::SliceMixture g = make_slice_mixture({1.0}, {0.1, 0.5}, {0.05, 0.01, 0.08});
  for (std::size_t t = 0; t < 30; ++t)
    for (std::size_t p = 0; p < 60; ++p) lobe.w[t * 60 + p] = g.pdf_param(s.theta[t], s.phi[p]) * h * axis_step(s.phi);
  CHECK(l1_rel_error(lobe, g) < 1e-6);
}

TEST_CASE("a sweep that fails on a bad cell leaves no output and no checkpoint", "[fit][crash]") {
  Progress::set_enabled(false);
  TableMeta meta = make_grid(Domain::Fiber, 3, 1, 10, 20, true);
  std::vector<float> v(meta.n_slices() * meta.cells_per_slice(), 1.0f);
  v[2 * 200 + 7] = std::numeric_limits<float>::quiet_NaN();
  const std::string table = (temp_dir() / "nan_cell.h5").string();
  write_table(table, meta, v);
  FitSection f = fit_settings("nan_cell");
  f.batch = 8;  // one batch: the failure comes before any commit
  fs::remove_all(f.output + ".parts");
  CHECK_THROWS_WITH(run_sweep(table, f, ""), Catch::Contains("cell (theta_i 0, phi_i 7): NaN"));
  CHECK_FALSE(fs::exists(f.output));
  CHECK_FALSE(fs::exists(f.output + ".parts"));
  CHECK_FALSE(fs::exists(f.report));
}

TEST_CASE("candidate K values cover the range", "[fit][search]") {
  CHECK(candidate_ks(1, 8) == std::vector<int>{1, 2, 3, 4, 5, 6, 7, 8});
  CHECK(candidate_ks(1, 32) == std::vector<int>{1, 2, 3, 4, 5, 6, 7, 8, 10, 12, 16, 20, 24, 32});
  CHECK(candidate_ks(5, 5) == std::vector<int>{5});
  CHECK(candidate_ks(3, 11) == std::vector<int>{3, 4, 5, 6, 7, 8, 10, 11});
}

TEST_CASE("the criterion trades error against components", "[fit][search]") {
  std::vector<Candidate> c = {{1, 0.30, true}, {2, 0.10, true}, {3, 0.012, true}, {4, 0.010, true}, {5, 0.009, true}};
  CHECK(c[choose_candidate(c, 0.004, std::nullopt)].k == 3);  // the 4th component buys only 0.2%
  CHECK(c[choose_candidate(c, 0.0001, std::nullopt)].k == 5);
  CHECK(c[choose_candidate(c, 0.004, 0.05)].k == 3);          // smallest meeting 5%
  CHECK(c[choose_candidate(c, 0.004, 0.001)].k == 5);         // none meets: the largest
  c[2].ok = false;
  CHECK(c[choose_candidate(c, 0.004, std::nullopt)].k == 4);
  for (auto& x : c) x.ok = false;
  CHECK_THROWS_AS(choose_candidate(c, 0.004, std::nullopt), Error);
}

TEST_CASE("scene-driven plans fit the slices around each direction", "[fit][plan]") {
  const TableMeta m = make_grid(Domain::Fiber, 10, 1, 4, 8, true);  // theta_o centers every 18 degrees
  CHECK(plan_slices(m, {}, {}).size() == 10);
  const auto p = plan_slices(m, {m.theta_o[3] + 0.1}, {});
  REQUIRE(p.size() == 2);
  CHECK(p[0].t_o == 3);
  CHECK(p[1].t_o == 4);
  CHECK(plan_slices(m, {m.theta_o[3]}, {}).size() == 1);
  CHECK(plan_slices(m, {-1.57}, {}).front().t_o == 0);
  const TableMeta n = make_grid(Domain::Hemisphere, 4, 8, 4, 8, false);
  const auto q = plan_slices(n, {n.theta_o[1] + 0.05}, {3.1});  // phi_o wraps around to cell 0
  REQUIRE(q.size() == 4);
  CHECK(q[0].index == 1 * 8 + 0);
  CHECK(q[1].index == 1 * 8 + 7);
}

TEST_CASE("the search picks the K a slice deserves", "[fit][search]") {
  Progress::set_enabled(false);
  // Slice 0: three well separated Gaussians. Slice 1: one smooth lobe.
  // Slice 2: a sharp multi-lobe slice (6 narrow lobes). Slice 3: a broad slice (2 wide lobes).
  const std::string table = mixture_table("known.h5", 4, 60, 120, [](std::size_t t) -> std::vector<Lobe> {
    switch (t) {
      case 0: return {{0.5, -0.6, -1.5, 0.02, 0.005, 0.05}, {0.3, 0.3, 0.8, 0.03, -0.01, 0.08}, {0.2, 0.7, 2.4, 0.01, 0.0, 0.04}};
      case 1: return {{1.0, 0.1, 0.4, 0.08, 0.02, 0.3}};
      case 2: {
        std::vector<Lobe> l;
        for (int i = 0; i < 6; ++i) l.push_back({1.0 / 6, -0.9 + 0.35 * i, -2.6 + 1.0 * i, 0.004, 0.0, 0.01});
        return l;
      }
      default: return {{0.6, -0.3, -1.0, 0.2, 0.0, 0.8}, {0.4, 0.4, 1.5, 0.25, 0.05, 1.0}};
    }
  });
  FitSection f = fit_settings("known");
  f.k_max = 10;
  const SweepSummary s = run_sweep(table, f, "");
  CHECK(s.slices == 4);
  const MixtureFile m = read_mixture_file(f.output);
  REQUIRE(m.slices() == 4);
  INFO("chosen K: " << m.k[0] << " " << m.k[1] << " " << m.k[2] << " " << m.k[3]);
  CHECK(m.k[0] == 3);
  CHECK(m.k[1] <= 2);
  CHECK(m.k[2] > m.k[3]);
  for (std::size_t i = 0; i < 4; ++i) {
    INFO("slice " << i << " l1 " << m.l1_rel[i]);
    CHECK(m.l1_rel[i] < 0.03);
  }
  // The CSVs follow their contracts.
  const std::string report = slurp(f.report), search = slurp(f.search_report);
  CHECK(report.rfind("slice,theta_o,phi_o,k,iterations,loglik,l1_rel,seconds,device,status\n", 0) == 0);
  CHECK(std::count(report.begin(), report.end(), ',') == 5 * 9);  // 10 fields a row, no comma inside one
  CHECK(search.rfind("slice,k,restart,loglik,l1_rel,score,chosen\n", 0) == 0);
  CHECK(std::count(report.begin(), report.end(), '\n') == 5);
  // 4 slices x 9 candidates (1..8, 10) x 2 restarts, one chosen K per slice (2 rows each).
  CHECK(std::count(search.begin(), search.end(), '\n') == 1 + 4 * 9 * 2);
  std::size_t chosen_rows = 0;
  std::istringstream lines(search);
  std::string line;
  while (std::getline(lines, line)) chosen_rows += line.size() > 2 && line.substr(line.size() - 2) == ",1";
  CHECK(chosen_rows == 4 * 2);
  CHECK_FALSE(fs::exists(f.output + ".parts"));
}

TEST_CASE("an error target picks the smallest K that meets it", "[fit][search]") {
  Progress::set_enabled(false);
  const std::string table = mixture_table("target.h5", 1, 40, 80, [](std::size_t) -> std::vector<Lobe> {
    return {{0.5, -0.5, -1.0, 0.02, 0.0, 0.05}, {0.3, 0.3, 1.0, 0.03, 0.0, 0.05}, {0.2, 0.6, 2.5, 0.02, 0.0, 0.05}};
  });
  FitSection f = fit_settings("target");
  f.error_target = 1.9;  // one Gaussian meets any target this loose
  run_sweep(table, f, "");
  CHECK(read_mixture_file(f.output).k[0] == 1);
  f.error_target = 0.7;  // two cover the two heaviest lobes (L1 about 0.5)
  run_sweep(table, f, "");
  CHECK(read_mixture_file(f.output).k[0] == 2);
  f.error_target = 0.02;
  run_sweep(table, f, "");
  CHECK(read_mixture_file(f.output).k[0] == 3);
}

TEST_CASE("zero slices are stored with scale 0 and never NaN", "[fit]") {
  Progress::set_enabled(false);
  const std::string table = mixture_table("zero.h5", 2, 20, 40, [](std::size_t t) -> std::vector<Lobe> {
    if (t == 0) return {};
    return {{1.0, 0.0, 0.0, 0.05, 0.0, 0.1}};
  });
  FitSection f = fit_settings("zero");
  f.k_max = 3;
  run_sweep(table, f, "");
  const MixtureFile m = read_mixture_file(f.output);
  CHECK(m.scale[0] == 0.0);
  CHECK(m.k[0] == 1);
  CHECK(std::isfinite(m.loglik[0]));
  CHECK(m.scale[1] > 0);
  const std::string report = slurp(f.report);
  CHECK_THAT(report, Catch::Contains(",zero: every cell is zero; stored with scale 0\n"));
  CHECK_THAT(report, Catch::Contains(",ok\n"));
}

TEST_CASE("a slice with fewer non-zero cells than K gets one component per cell", "[fit]") {
  Progress::set_enabled(false);
  TableMeta meta = make_grid(Domain::Fiber, 1, 1, 20, 40, true);
  std::vector<float> v(meta.cells_per_slice(), 0.0f);
  v[5 * 40 + 3] = 2.0f;
  v[9 * 40 + 20] = 1.0f;
  v[14 * 40 + 33] = 0.5f;
  const std::string table = (temp_dir() / "three_cells.h5").string();
  write_table(table, meta, v);
  FitSection f = fit_settings("three_cells");
  f.k_min = f.k_max = 8;
  run_sweep(table, f, "");
  const MixtureFile m = read_mixture_file(f.output);
  CHECK(m.k[0] == 3);
  for (float x : m.weights) CHECK(std::isfinite(x));
  for (float x : m.covariances) CHECK(std::isfinite(x));
  // Three components at the covariance floor, one on each cell: each holds most of its
  // mass in its cell (its center density times the cell area would overstate it 2.5x).
  CHECK(m.l1_rel[0] < 0.4);
  CHECK_THAT(slurp(f.report), Catch::Contains(",reduced: K lowered from 8 to 3; the number of non-zero cells\n"));
}

TEST_CASE("an interrupted sweep resumes to the same file", "[fit][crash]") {
  Progress::set_enabled(false);
  const std::string table = mixture_table("resume.h5", 12, 30, 60, [](std::size_t t) -> std::vector<Lobe> {
    return {{0.6, -0.4 + 0.05 * double(t), -1.0, 0.03, 0.0, 0.06}, {0.4, 0.5, 1.5 - 0.1 * double(t), 0.02, 0.005, 0.05}};
  });
  FitSection whole = fit_settings("whole");
  whole.batch = 3;
  whole.k_max = 4;
  run_sweep(table, whole, "");
  const MixtureFile a = read_mixture_file(whole.output);

  // The same sweep stopped after two batches, then rerun: it resumes from the
  // committed batches and ends with the same file.
  FitSection part = whole;
  part.output = (temp_dir() / "part_mixture.h5").string();
  part.report = (temp_dir() / "part_fit.csv").string();
  part.search_report = (temp_dir() / "part_search.csv").string();
  fs::remove_all(part.output + ".parts");
  fs::remove(part.output);
  const SweepSummary first = run_sweep(table, part, "", 2);
  CHECK_FALSE(first.complete);
  CHECK_FALSE(fs::exists(part.output));
  const SweepSummary second = run_sweep(table, part, "");
  CHECK(second.complete);
  CHECK(second.resumed == 6);
  const MixtureFile b = read_mixture_file(part.output);
  CHECK(a.k == b.k);
  CHECK(a.weights == b.weights);
  CHECK(a.means == b.means);
  CHECK(a.covariances == b.covariances);
  CHECK(a.scale == b.scale);
  CHECK(a.l1_rel == b.l1_rel);
  CHECK(slurp(whole.search_report) == slurp(part.search_report));
}

TEST_CASE("kill -9 at random moments never leaves a bad file, and a rerun resumes to the same result", "[fit][crash]") {
  const fs::path dir = temp_dir() / "kill";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string table = mixture_table("kill.h5", 32, 40, 80, [](std::size_t t) -> std::vector<Lobe> {
    return {{0.4, -0.5 + 0.03 * double(t), -0.5, 0.02, 0.0, 0.05},
            {0.3, 0.4, 1.0 + 0.05 * double(t), 0.03, 0.0, 0.04},
            {0.3, 0.0, 2.8, 0.01, 0.0, 0.2}};
  });
  auto write_config = [&](const std::string& stem) {
    const std::string cfg = (dir / (stem + ".yaml")).string();
    std::ofstream(cfg) << "table: " << table << "\nfit:\n  output: " << (dir / (stem + "_mixture.h5")).string()
                       << "\n  report: " << (dir / (stem + "_fit.csv")).string()
                       << "\n  search_report: " << (dir / (stem + "_search.csv")).string()
                       << "\n  k_max: 8\n  restarts: 2\n  final_restarts: 2\n  batch: 2\n";
    return cfg;
  };
  const std::string ref_cfg = write_config("ref"), cfg = write_config("killed");
  const std::string bin = BSDFMIX_BINARY;
  const auto t0 = std::chrono::steady_clock::now();
  REQUIRE(std::system((bin + " fit -q " + ref_cfg).c_str()) == 0);
  const int ref_ms = int(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
  const MixtureFile ref = read_mixture_file((dir / "ref_mixture.h5").string());

  // Kill each attempt at a random moment of what an uninterrupted run takes; each
  // attempt resumes the previous ones' committed batches.
  std::mt19937 rng(12345);
  std::uniform_int_distribution<int> delay_ms(ref_ms / 20, ref_ms / 3);
  INFO("uninterrupted run: " << ref_ms << " ms");
  int kills = 0;
  bool finished = false;
  for (int attempt = 0; attempt < 8; ++attempt) {
    const pid_t pid = fork();
    if (pid == 0) {
      execl(bin.c_str(), bin.c_str(), "fit", "-q", cfg.c_str(), static_cast<char*>(nullptr));
      _exit(127);
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(delay_ms(rng)));
    kills += kill(pid, SIGKILL) == 0;
    int status = 0;
    waitpid(pid, &status, 0);
    // The mixture file is either absent or complete (readable and valid).
    const std::string out = (dir / "killed_mixture.h5").string();
    if (fs::exists(out)) {
      CHECK_NOTHROW(read_mixture_file(out));
      finished = true;
      break;  // the run finished before the kill
    }
  }
  CHECK(kills > 0);
  const std::string summary = (dir / "summary.txt").string();
  REQUIRE(std::system((bin + " fit -q " + cfg + " > " + summary).c_str()) == 0);
  // The rerun resumed from batches the killed runs had committed.
  const std::string text = slurp(summary);
  INFO(text);
  const auto at = text.find(" resumed from checkpoint");
  REQUIRE(at != std::string::npos);
  const std::size_t open = text.rfind('(', at);
  const int resumed = std::stoi(text.substr(open + 1, at - open - 1));
  if (!finished) CHECK(resumed > 0);
  CHECK(resumed < 32);
  const MixtureFile got = read_mixture_file((dir / "killed_mixture.h5").string());
  CHECK(got.k == ref.k);
  CHECK(got.weights == ref.weights);
  CHECK(got.means == ref.means);
  CHECK(got.covariances == ref.covariances);
  CHECK(got.l1_rel == ref.l1_rel);
  CHECK(slurp((dir / "killed_search.csv").string()) == slurp((dir / "ref_search.csv").string()));
  for (const auto& e : fs::directory_iterator(dir))
    CHECK(e.path().filename().string().find(".partial-") == std::string::npos);
}
