// The fitting sweep: the Gaussian-count criterion, scene-driven slice plans, the outputs,
// and crash safety (an interrupted sweep resumes to the same result; kill -9 leaves no
// half-written file).
// labels: fit
#include <catch2/catch.hpp>

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <hdf5.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <random>
#include <sstream>
#include <thread>

#include "config/config.hpp"
#include "core/error.hpp"
#include "core/output_lock.hpp"
#include "core/progress.hpp"
#include "io/mixture_file.hpp"
#include "io/table.hpp"
#include "sweep/batch_fitter.hpp"
#include "sweep/criterion.hpp"
#include "sweep/fit_error.hpp"
#include "sweep/fit_slices.hpp"
#include "sweep/slice_plan.hpp"
#include "sweep/slice_source.hpp"
#include "sweep/sweep.hpp"

using namespace bsdfmix;
namespace fs = std::filesystem;

namespace {

// A sweep that stops after committing n batches.
SweepOptions stop_after(std::size_t n) {
  SweepOptions o;
  o.max_batches = n;
  return o;
}

fs::path temp_dir() {
  const fs::path d = fs::temp_directory_path() / "bsdfmix_sweep_test";
  fs::create_directories(d);
  return d;
}

struct Lobe {
  double w, mt, mp, stt, stp, spp;
};

// A fiber table whose slice t is f such that the integrand weights are the mixture
// of `lobes(t)` (f = density / cos(theta)); with `colour`, an rgb channel too: lobe k
// tinted by the k-th of a few colours.
template <class Lobes>
std::string mixture_table(const std::string& name, std::size_t n_theta_o, std::size_t nt, std::size_t np, Lobes lobes,
                          bool colour = false) {
  static const double tints[3][3] = {{0.9, 0.4, 0.2}, {0.3, 0.8, 0.5}, {0.2, 0.3, 0.9}};
  TableMeta m = make_grid(Domain::Fiber, n_theta_o, 1, nt, np, true);
  m.source = R"({"model": "test mixture"})";
  m.rgb = colour;
  const std::string path = (temp_dir() / name).string();
  TableWriter out(path, m);
  for (std::size_t t = 0; t < n_theta_o; ++t) {
    std::vector<mix::SliceMixture> parts;
    std::vector<double> wk;
    for (const Lobe& l : lobes(t)) {
      parts.push_back(make_slice_mixture({1.0}, {l.mt, l.mp}, {l.stt, l.stp, l.spp}));
      wk.push_back(l.w);
    }
    double wsum = 0;
    for (double x : wk) wsum += x;
    std::vector<float> v(nt * np, 0.0f), rgb(3 * nt * np, 0.0f);  // no lobes: an all-zero slice
    for (std::size_t i = 0; i < nt; ++i)
      for (std::size_t j = 0; j < np; ++j)
        for (std::size_t k = 0; k < parts.size(); ++k) {
          const double d = wk[k] / wsum * parts[k].pdf_param(m.theta_i[i], m.phi_i[j]) / std::cos(m.theta_i[i]);
          v[i * np + j] += float(d);
          for (int c = 0; c < 3; ++c) rgb[3 * (i * np + j) + std::size_t(c)] += float(d * tints[k % 3][c]);
        }
    out.write_slice(t, 0, v.data(), colour ? rgb.data() : nullptr);
  }
  out.commit();
  return path;
}

FitSettings fit_settings(const std::string& stem) {
  FitSettings f;
  f.map = "theta_phi";  // the tables are Gaussians in (theta, phi): their true K is known there
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

// A fiber table of `slices` slices of 10 x 20 cells, all 1 but for a NaN at cell `cell`
// (theta_i 0, phi_i `cell`) of slice `slice`.
std::string nan_table(const std::string& name, std::size_t slices, std::size_t slice, std::size_t cell) {
  const TableMeta meta = make_grid(Domain::Fiber, slices, 1, 10, 20, true);
  std::vector<float> v(meta.n_slices() * meta.cells_per_slice(), 1.0f);
  v[slice * meta.cells_per_slice() + cell] = std::numeric_limits<float>::quiet_NaN();
  const std::string path = (temp_dir() / name).string();
  write_table(path, meta, v);
  return path;
}

std::string slurp(const std::string& p) {
  std::ifstream f(p);
  return std::string((std::istreambuf_iterator<char>(f)), {});
}

// A CSV file's lines with column `drop` (0-based) removed from each.
std::vector<std::string> without_column(const std::string& text, std::size_t drop) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) {
    std::string kept;
    std::size_t col = 0, at = 0;
    for (;; ++col) {
      const std::size_t comma = line.find(',', at);
      if (col != drop) kept += (kept.empty() && col == 0 ? "" : ",") + line.substr(at, comma - at);
      if (comma == std::string::npos) break;
      at = comma + 1;
    }
    lines.push_back(kept);
  }
  return lines;
}

std::string g9(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.9g", v);
  return buf;
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
  const std::string table = nan_table("nan_cell.h5", 3, 2, 7);
  FitSettings f = fit_settings("nan_cell");
  f.batch = 8;  // one batch: the failure comes before any commit
  fs::remove_all(f.output + ".parts");
  CHECK_THROWS_WITH(run_sweep(table, f, ""), Catch::Contains("cell (theta_i 0, phi_i 7): NaN"));
  CHECK_FALSE(fs::exists(f.output));
  CHECK_FALSE(fs::exists(f.output + ".parts"));
  CHECK_FALSE(fs::exists(f.report));
}

TEST_CASE("a default batch holds 1/32 of the plan within [4, 64] slices and at most 2^20 cells", "[fit][batch]") {
  FitSettings fit;
  CHECK(batch_size(90, fit, 90 * 180) == 4);
  CHECK(batch_size(600, fit, 90 * 180) == 18);
  CHECK(batch_size(64800, fit, 90 * 180) == 64);
  CHECK(batch_size(241, fit, 362 * 1440) == 2);   // cg_sunflower's resolved grid
  CHECK(batch_size(241, fit, 3000 * 1440) == 1);  // a slice past the cap still fits
  fit.batch = 10;
  CHECK(batch_size(241, fit, 362 * 1440) == 10);  // as configured
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
  // an axis value a few ulps off (written out and read back) is still that one slice
  const TableMeta r = make_grid(Domain::Hemisphere, 30, 1, 4, 8, true);
  for (std::size_t t = 0; t < r.theta_o.size(); ++t)
    for (double x : {std::nextafter(std::nextafter(r.theta_o[t], 0.0), 0.0), r.theta_o[t],
                     std::nextafter(std::nextafter(r.theta_o[t], 9.0), 9.0)}) {
      const auto one = plan_slices(r, {x}, {});
      INFO("theta_o row " << t << " at " << x);
      REQUIRE(one.size() == 1);
      CHECK(one[0].t_o == t);
    }
  CHECK(plan_slices(m, {-1.57}, {}).front().t_o == 0);
  const TableMeta n = make_grid(Domain::Hemisphere, 4, 8, 4, 8, false);
  const auto q = plan_slices(n, {n.theta_o[1] + 0.05}, {3.1});  // phi_o wraps around to cell 0
  REQUIRE(q.size() == 4);
  CHECK(q[0].index == 1 * 8 + 0);
  CHECK(q[1].index == 1 * 8 + 7);
}

TEST_CASE("rows chosen by stride, index and degrees", "[fit][plan]") {
  CHECK(stride_rows(10, 3) == std::vector<std::size_t>{0, 3, 6, 9});
  CHECK(stride_rows(10, 4) == std::vector<std::size_t>{0, 4, 8, 9});  // the last row always kept
  CHECK(stride_rows(10, 20) == std::vector<std::size_t>{0, 9});
  CHECK(stride_rows(3, 1) == std::vector<std::size_t>{0, 1, 2});
  const TableMeta m = make_grid(Domain::Hemisphere, 10, 1, 4, 8, true);  // rows at 4.5, 13.5, ... 85.5 degrees
  FitSettings f;
  CHECK(plan_fit_slices(m, f).size() == 10);
  f.theta_o_stride = 4;
  CHECK(chosen_rows(m.theta_o, f) == std::vector<std::size_t>{0, 4, 8, 9});
  f.theta_o_rows = {2, 4};
  f.theta_o_deg = {10, 37};  // nearest rows: 13.5 (1), 40.5 (4)
  CHECK(chosen_rows(m.theta_o, f) == std::vector<std::size_t>{0, 1, 2, 4, 8, 9});
  f.theta_o_stride = 0;
  f.theta_o = {m.theta_o[6] + 0.01};  // radians add the two rows around
  const std::vector<SliceRef> p = plan_fit_slices(m, f);
  std::vector<std::size_t> rows;
  for (const SliceRef& r : p) rows.push_back(r.t_o);
  CHECK(rows == std::vector<std::size_t>{1, 2, 4, 6, 7});
  f.theta_o_rows = {10};
  CHECK_THROWS_WITH(chosen_rows(m.theta_o, f), Catch::Contains("fit.theta_o_rows: row 10 is past the table's 10 theta_o rows"));
  // without symmetry a row holds every phi_o slice
  const TableMeta n = make_grid(Domain::Hemisphere, 4, 3, 4, 8, false);
  FitSettings g;
  g.theta_o_rows = {1};
  const std::vector<SliceRef> q = plan_fit_slices(n, g);
  REQUIRE(q.size() == 3);
  CHECK(q[0].index == 3);
  CHECK(q[2].index == 5);
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
  for (const std::string method : {"smem", "restarts"}) {
    INFO("search: " << method);
    FitSettings f = fit_settings("known_" + method);
    f.k_max = 10;
    f.search = *search_strategy(method);
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
    CHECK(report.rfind("slice,theta_o,phi_o,k,iterations,loglik,l1_rel,seconds,device,status,rgb_l1_rel,rgb_negative,"
                       "defensive,max_weight\n",
                       0) == 0);
    CHECK(std::count(report.begin(), report.end(), ',') == 5 * 13);  // 14 fields a row, no comma inside one
    CHECK(std::count(report.begin(), report.end(), '\n') == std::count(report.begin(), report.end(), ',') / 13);
    CHECK_THAT(report, Catch::Contains(",ok,,,"));  // no rgb: the colour columns are empty
    CHECK(search.rfind("slice,k,restart,loglik,l1_rel,score,chosen\n", 0) == 0);
    CHECK(std::count(report.begin(), report.end(), '\n') == 5);
    std::size_t rows = 0;
    std::map<std::string, int> chosen_per_slice;
    std::istringstream lines(search);
    std::string line;
    std::getline(lines, line);
    while (std::getline(lines, line)) {
      ++rows;
      CHECK(std::count(line.begin(), line.end(), ',') == 6);
      if (line.substr(line.size() - 2) == ",1") chosen_per_slice[line.substr(0, line.find(','))]++;
    }
    if (method == "restarts") {
      // 4 slices x 9 candidates (1..8, 10) x 2 restarts, one chosen K per slice (2 rows each).
      CHECK(rows == 4 * 9 * 2);
      CHECK(chosen_per_slice == std::map<std::string, int>{{"0", 2}, {"1", 2}, {"2", 2}, {"3", 2}});
    } else {
      // One row per slice and K walked (the walk stops early), one chosen row per slice.
      CHECK(rows >= 4 * 2);
      CHECK(rows <= 4 * 9);
      CHECK(chosen_per_slice == std::map<std::string, int>{{"0", 1}, {"1", 1}, {"2", 1}, {"3", 1}});
    }
    CHECK_FALSE(fs::exists(f.output + ".parts"));
  }
}

TEST_CASE("an error target picks the smallest K that meets it", "[fit][search]") {
  Progress::set_enabled(false);
  const std::string table = mixture_table("target.h5", 1, 40, 80, [](std::size_t) -> std::vector<Lobe> {
    return {{0.5, -0.5, -1.0, 0.02, 0.0, 0.05}, {0.3, 0.3, 1.0, 0.03, 0.0, 0.05}, {0.2, 0.6, 2.5, 0.02, 0.0, 0.05}};
  });
  FitSettings f = fit_settings("target");
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
  FitSettings f = fit_settings("zero");
  f.k_max = 3;
  run_sweep(table, f, "");
  const MixtureFile m = read_mixture_file(f.output);
  CHECK(m.scale[0] == 0.0);
  CHECK(m.k[0] == 1);
  CHECK(std::isfinite(m.loglik[0]));
  CHECK(m.scale[1] > 0);
  const std::string report = slurp(f.report);
  CHECK_THAT(report, Catch::Contains(",zero: every cell is zero; stored with scale 0,,,"));
  CHECK_THAT(report, Catch::Contains(",ok,,,"));  // the empty colour columns, then defensive
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
  FitSettings f = fit_settings("three_cells");
  f.k_min = f.k_max = 8;
  run_sweep(table, f, "");
  const MixtureFile m = read_mixture_file(f.output);
  CHECK(m.k[0] == 3);
  for (float x : m.weights) CHECK(std::isfinite(x));
  for (float x : m.covariances) CHECK(std::isfinite(x));
  // Three components at the covariance floor, one on each cell: each holds most of its
  // mass in its cell (its center density times the cell area would overstate it 2.5x).
  CHECK(m.l1_rel[0] < 0.4);
  CHECK_THAT(slurp(f.report), Catch::Contains(",reduced: K lowered from 8 to 3; the number of non-zero cells,,,"));
}

TEST_CASE("an interrupted sweep resumes to the same file", "[fit][crash]") {
  Progress::set_enabled(false);
  for (const bool colour : {false, true}) {
  INFO((colour ? "a table with rgb" : "a table without rgb"));
  const std::string table = mixture_table(colour ? "resume_rgb.h5" : "resume.h5", 12, 30, 60, [](std::size_t t) -> std::vector<Lobe> {
    return {{0.6, -0.4 + 0.05 * double(t), -1.0, 0.03, 0.0, 0.06}, {0.4, 0.5, 1.5 - 0.1 * double(t), 0.02, 0.005, 0.05}};
  }, colour);
  FitSettings whole = fit_settings(colour ? "whole_rgb" : "whole");
  whole.batch = 3;
  whole.k_max = 4;
  run_sweep(table, whole, "");
  const MixtureFile a = read_mixture_file(whole.output);

  // The same sweep stopped after two batches, then rerun: it resumes from the
  // committed batches and ends with the same file.
  FitSettings part = whole;
  part.output = (temp_dir() / (colour ? "part_rgb_mixture.h5" : "part_mixture.h5")).string();
  part.report = (temp_dir() / (colour ? "part_rgb_fit.csv" : "part_fit.csv")).string();
  part.search_report = (temp_dir() / (colour ? "part_rgb_search.csv" : "part_search.csv")).string();
  fs::remove_all(part.output + ".parts");
  fs::remove(part.output);
  const SweepSummary first = run_sweep(table, part, "", stop_after(2));
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
  CHECK(a.rgb_scale == b.rgb_scale);
  CHECK(a.rgb_copies == b.rgb_copies);
  CHECK(a.has_rgb() == colour);
  CHECK(slurp(whole.search_report) == slurp(part.search_report));
  // The report rows come back from the part files as they were fitted (but the time), the
  // colour columns with them.
  CHECK(without_column(slurp(whole.report), 7) == without_column(slurp(part.report), 7));
  if (colour) CHECK_THAT(slurp(part.report), !Catch::Contains(",ok,,\n"));
  }
}

TEST_CASE("batches fitted side by side give the file one lane gives; a lane's error stops the sweep", "[fit][crash]") {
  Progress::set_enabled(false);
  const std::string table = mixture_table("lanes.h5", 9, 30, 60, [](std::size_t t) -> std::vector<Lobe> {
    return {{0.7, -0.3 + 0.05 * double(t), -0.5, 0.03, 0.0, 0.06}, {0.3, 0.6, 1.0 - 0.1 * double(t), 0.02, 0.005, 0.05}};
  });
  std::map<unsigned, MixtureFile> files;
  std::map<unsigned, std::string> reports;
  for (const unsigned lanes : {1u, 2u, 3u}) {
    FitSettings f = fit_settings("lanes" + std::to_string(lanes));
    f.batch = 2;  // 5 batches: every lane takes several, and they finish out of order
    f.k_max = 4;
    fs::remove_all(f.output + ".parts");
    SweepOptions o;
    o.lanes = lanes;
    CHECK(run_sweep(table, f, "", o).slices == 9);
    files.emplace(lanes, read_mixture_file(f.output));
    reports.emplace(lanes, slurp(f.report));
  }
  for (const unsigned lanes : {2u, 3u}) {
    INFO(lanes << " lanes");
    const MixtureFile& a = files.at(1);
    const MixtureFile& b = files.at(lanes);
    CHECK(a.k == b.k);
    CHECK(a.weights == b.weights);
    CHECK(a.means == b.means);
    CHECK(a.covariances == b.covariances);
    CHECK(a.l1_rel == b.l1_rel);
    CHECK(without_column(reports.at(1), 7) == without_column(reports.at(lanes), 7));
  }

  // A NaN in the last slice: its lane throws, the others stop, and the error reaches the
  // caller with the cell named; no final file is written.
  const std::string bad = nan_table("lanes_nan.h5", 6, 5, 3);
  FitSettings f = fit_settings("lanes_nan");
  f.batch = 1;
  fs::remove_all(f.output + ".parts");
  SweepOptions o;
  o.lanes = 2;
  CHECK_THROWS_WITH(run_sweep(bad, f, "", o), Catch::Contains("cell (theta_i 0, phi_i 3): NaN"));
  CHECK_FALSE(fs::exists(f.output));
  fs::remove_all(f.output + ".parts");
}

namespace {

// Slices held in memory: the integrand weights of a table's slices, read once.
class MemorySlices final : public SliceSource {
 public:
  explicit MemorySlices(const std::string& table) {
    const TableReader reader(table);
    meta_ = reader.meta();
    const TableSlices slices(reader);
    for (const SliceRef& r : plan_slices(meta_, {}, {})) {
      weights_.push_back(slices.weights(r));
      if (meta_.rgb) rgb_.push_back(slices.rgb_weights(r));
    }
  }
  const TableMeta& meta() const override { return meta_; }
  std::vector<double> weights(const SliceRef& ref) const override { return weights_.at(ref.index); }
  std::vector<double> rgb_weights(const SliceRef& ref) const override { return rgb_.at(ref.index); }

 private:
  TableMeta meta_;
  std::vector<std::vector<double>> weights_, rgb_;
};

}  // namespace

TEST_CASE("fit_slices fits in memory what the file sweep fits", "[fit][sweep]") {
  Progress::set_enabled(false);
  const std::string table = mixture_table("in_memory.h5", 7, 30, 60, [](std::size_t t) -> std::vector<Lobe> {
    if (t == 4) return {};  // an all-zero slice
    return {{0.7, -0.3 + 0.08 * double(t), 0.5, 0.02, 0.0, 0.05}, {0.3, 0.6, -2.0 + 0.3 * double(t), 0.04, 0.01, 0.2}};
  }, true);
  for (const SearchStrategy search : {SearchStrategy::Smem, SearchStrategy::Restarts}) {
    INFO("search: " << search_name(search));
    FitSettings f = fit_settings(std::string("in_memory_") + search_name(search));
    f.k_max = 4;
    f.batch = 3;
    f.search = search;
    run_sweep(table, f, "");
    const MixtureFile file = read_mixture_file(f.output);

    const MemorySlices memory(table);
    std::vector<SliceRef> slices = plan_slices(memory.meta(), {}, {});
    const SweepResult r = fit_slices(memory, slices, f, select_devices(""), "fit in memory");
    const MixtureFile& m = r.mixture;
    REQUIRE(m.slices() == file.slices());
    CHECK(m.k == file.k);
    CHECK(m.weights == file.weights);
    CHECK(m.means == file.means);
    CHECK(m.covariances == file.covariances);
    CHECK(m.scale == file.scale);
    CHECK(m.loglik == file.loglik);
    CHECK(m.l1_rel == file.l1_rel);
    CHECK(m.rgb_scale == file.rgb_scale);
    CHECK(m.rgb_copies == file.rgb_copies);
    CHECK(m.has_rgb());
    CHECK(m.theta_o == file.theta_o);
    CHECK(m.table_theta_o == file.table_theta_o);
    CHECK(m.fit_settings == file.fit_settings);
    CHECK(m.table_source == file.table_source);
    CHECK(r.failed() == 0);
    CHECK(r.slice_index == std::vector<std::size_t>{0, 1, 2, 3, 4, 5, 6});
    REQUIRE(r.report.size() == 7);
    CHECK(r.report[4].status == "zero: every cell is zero; stored with scale 0");
    CHECK_FALSE(r.report[4].failed());

    // Its rows are the file sweep's CSV rows.
    std::string report =
        "slice,theta_o,phi_o,k,iterations,loglik,l1_rel,device,status,rgb_l1_rel,rgb_negative,defensive,max_weight\n";
    for (const ReportRow& row : r.report)
      report += std::to_string(row.slice) + "," + g9(row.theta_o) + "," + g9(row.phi_o) + "," +
                std::to_string(row.k) + "," + std::to_string(row.iterations) + "," + g9(row.loglik) + "," +
                g9(row.l1_rel) + "," + row.device + "," + row.status + "," + g9(row.rgb_l1_rel) + "," +
                g9(row.rgb_negative) + "," + g9(row.defensive) + "," + g9(row.max_weight) + "\n";
    CHECK(without_column(report, 99) == without_column(slurp(f.report), 7));
    std::string search_csv = "slice,k,restart,loglik,l1_rel,score,chosen\n";
    for (const SearchRow& row : r.search)
      search_csv += std::to_string(row.slice) + "," + std::to_string(row.k) + "," + std::to_string(row.restart) + "," +
                    g9(row.loglik) + "," + g9(row.l1_rel) + "," + g9(row.score) + "," + (row.chosen ? "1" : "0") + "\n";
    CHECK(search_csv == slurp(f.search_report));
    CHECK_FALSE(r.search.empty());

    // A part of the slices, and slices out of order, refused.
    slices.erase(slices.begin(), slices.begin() + 5);
    const SweepResult tail = fit_slices(memory, slices, f, select_devices(""), "fit in memory");
    CHECK(tail.slice_index == std::vector<std::size_t>{5, 6});
    std::swap(slices[0], slices[1]);
    CHECK_THROWS_AS(fit_slices(memory, slices, f, select_devices(""), "fit in memory"), Error);
  }
}

namespace {

// Committed part files of a checkpoint directory (temporaries of a killed writer excluded).
std::size_t committed_parts(const fs::path& parts) {
  std::error_code ec;
  std::size_t n = 0;
  for (fs::directory_iterator it(parts, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    n += name.rfind("batch_", 0) == 0 && name.find(".partial-") == std::string::npos && it->path().extension() == ".h5";
  }
  return n;
}

std::string run_captured(const std::string& cmd, int* rc) {
  const std::string out = (temp_dir() / "captured.txt").string();
  *rc = std::system((cmd + " > " + out + " 2>&1").c_str());
  return slurp(out);
}

}  // namespace

// The kills are placed by events, not by a clock: each attempt is killed right after
// it is seen to commit a chosen number of batches (the first attempt after its first),
// at a random point of the batch it is then fitting or writing. The outcome is the
// same on a fast or a slow machine.
TEST_CASE("kill -9 during a sweep never leaves a bad file, and a rerun resumes to the same result", "[fit][crash]") {
  const fs::path dir = temp_dir() / "kill";
  fs::remove_all(dir);
  fs::create_directories(dir);
  constexpr std::size_t kSlices = 32, kBatch = 2, kBatches = kSlices / kBatch;
  const std::string table = mixture_table("kill.h5", kSlices, 40, 80, [](std::size_t t) -> std::vector<Lobe> {
    return {{0.4, -0.5 + 0.03 * double(t), -0.5, 0.02, 0.0, 0.05},
            {0.3, 0.4, 1.0 + 0.05 * double(t), 0.03, 0.0, 0.04},
            {0.3, 0.0, 2.8, 0.01, 0.0, 0.2}};
  });
  auto write_config = [&](const std::string& stem) {
    const std::string cfg = (dir / (stem + ".yaml")).string();
    std::ofstream(cfg) << "table: " << table << "\nfit:\n  output: " << (dir / (stem + "_mixture.h5")).string()
                       << "\n  report: " << (dir / (stem + "_fit.csv")).string()
                       << "\n  search_report: " << (dir / (stem + "_search.csv")).string()
                       << "\n  k_max: 8\n  restarts: 2\n  final_restarts: 2\n  batch: " << kBatch << "\n";
    return cfg;
  };
  const std::string ref_cfg = write_config("ref"), cfg = write_config("killed");
  const std::string bin = BSDFMIX_BINARY;
  REQUIRE(std::system((bin + " fit -q " + ref_cfg).c_str()) == 0);
  const MixtureFile ref = read_mixture_file((dir / "ref_mixture.h5").string());
  const std::string out = (dir / "killed_mixture.h5").string();
  const fs::path parts = out + ".parts";

  std::mt19937 rng(12345);
  int kills = 0;
  std::size_t target = 0;
  for (int attempt = 0; attempt < 6; ++attempt) {
    // Kill once `target` batches are committed; never past three quarters of the
    // sweep, so no attempt can finish it.
    target = attempt == 0 ? 1 : std::min<std::size_t>(committed_parts(parts) + 1 + rng() % 3, kBatches * 3 / 4);
    if (committed_parts(parts) >= target) break;
    const int extra_polls = int(rng() % 40);  // a random point within the next batch
    const pid_t pid = fork();
    if (pid == 0) {
      execl(bin.c_str(), bin.c_str(), "fit", "-q", cfg.c_str(), static_cast<char*>(nullptr));
      _exit(127);
    }
    int status = 0;
    bool exited = false;
    int polls_after = -1;
    while (!(exited = waitpid(pid, &status, WNOHANG) == pid)) {
      if (polls_after < 0 && committed_parts(parts) >= target) polls_after = 0;
      if (polls_after >= 0 && polls_after++ >= extra_polls) break;
      std::this_thread::sleep_for(std::chrono::microseconds(100));
    }
    INFO("attempt " << attempt << ", target " << target << " batches");
    REQUIRE_FALSE(exited);  // the run cannot end before a quarter of its batches are left
    kills += kill(pid, SIGKILL) == 0;
    waitpid(pid, &status, 0);
    REQUIRE((WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL));
    // Nothing half-written: no final file yet, and every committed part reads whole.
    CHECK_FALSE(fs::exists(out));
    for (const auto& e : fs::directory_iterator(parts)) {
      const std::string name = e.path().filename().string();
      if (name.rfind("batch_", 0) == 0 && name.find(".partial-") == std::string::npos)
        CHECK_NOTHROW(read_mixture_file(e.path().string()));
    }
  }
  CHECK(kills >= 1);
  const std::size_t committed = committed_parts(parts);
  REQUIRE(committed >= 1);
  REQUIRE(committed <= kBatches * 3 / 4 + 1);

  int rc = 0;
  const std::string text = run_captured(bin + " fit -q " + cfg, &rc);
  INFO(text);
  REQUIRE(rc == 0);
  // The rerun resumed exactly the batches the killed runs had committed.
  const auto at = text.find(" resumed from checkpoint");
  REQUIRE(at != std::string::npos);
  const std::size_t open = text.rfind('(', at);
  CHECK(std::stoul(text.substr(open + 1, at - open - 1)) == committed * kBatch);
  const MixtureFile got = read_mixture_file(out);
  CHECK(got.k == ref.k);
  CHECK(got.weights == ref.weights);
  CHECK(got.means == ref.means);
  CHECK(got.covariances == ref.covariances);
  CHECK(got.l1_rel == ref.l1_rel);
  CHECK(slurp((dir / "killed_search.csv").string()) == slurp((dir / "ref_search.csv").string()));
  for (const auto& e : fs::recursive_directory_iterator(dir))
    CHECK(e.path().filename().string().find(".partial-") == std::string::npos);
  CHECK_FALSE(fs::exists(parts));
  CHECK_FALSE(fs::exists(out + ".lock"));
}

TEST_CASE("a second run on the same output fails at once, naming the run that holds it", "[fit][crash]") {
  Progress::set_enabled(false);
  const std::string table = mixture_table("lock.h5", 2, 20, 40, [](std::size_t) -> std::vector<Lobe> {
    return {{1.0, 0.1, 0.5, 0.03, 0.0, 0.05}};
  });
  FitSettings f = fit_settings("lock");
  f.k_max = 2;
  fs::remove(f.output);
  const std::string cfg = (temp_dir() / "lock.yaml").string();
  std::ofstream(cfg) << "table: " << table << "\nfit:\n  output: " << f.output << "\n  report: " << f.report
                     << "\n  search_report: " << f.search_report << "\n  k_max: 2\n";
  {
    const OutputLock held(f.output);
    CHECK_THROWS_WITH(OutputLock(f.output), Catch::Contains("in use by another bsdfmix run (pid " +
                                                            std::to_string(getpid()) + " on "));
    int rc = 0;
    const std::string err = run_captured(std::string(BSDFMIX_BINARY) + " fit -q " + cfg, &rc);
    CHECK(rc != 0);
    CHECK(std::count(err.begin(), err.end(), '\n') == 1);
    CHECK_THAT(err, Catch::Contains(f.output + ": in use by another bsdfmix run (pid " + std::to_string(getpid())));
    CHECK_FALSE(fs::exists(f.output));
  }
  // Released (as a killed holder's lock is, with its process), the output is free.
  int rc = 0;
  run_captured(std::string(BSDFMIX_BINARY) + " fit -q " + cfg, &rc);
  CHECK(rc == 0);
  CHECK_NOTHROW(read_mixture_file(f.output));
  CHECK_FALSE(fs::exists(f.output + ".lock"));
}

TEST_CASE("a checkpoint is not reused after the table is rewritten with the same size and source", "[fit][crash]") {
  Progress::set_enabled(false);
  auto lobes_at = [](double mt) {
    return [mt](std::size_t t) -> std::vector<Lobe> {
      return {{0.7, mt + 0.02 * double(t), -1.0, 0.02, 0.0, 0.05}, {0.3, -0.3, 1.5, 0.03, 0.0, 0.04}};
    };
  };
  const std::string table = mixture_table("rewritten.h5", 6, 24, 48, lobes_at(0.2));
  const auto size_before = fs::file_size(table);
  FitSettings f = fit_settings("rewritten");
  f.batch = 2;
  f.k_max = 3;
  fs::remove_all(f.output + ".parts");
  CHECK_FALSE(run_sweep(table, f, "", stop_after(1)).complete);
  REQUIRE(fs::exists(f.output + ".parts"));

  // Same path, same size, same source attribute; other values.
  mixture_table("rewritten.h5", 6, 24, 48, lobes_at(-0.4));
  REQUIRE(fs::file_size(table) == size_before);
  const SweepSummary resumed = run_sweep(table, f, "");
  CHECK(resumed.resumed == 0);
  const MixtureFile got = read_mixture_file(f.output);

  FitSettings fresh = fit_settings("rewritten_fresh");
  fresh.batch = 2;
  fresh.k_max = 3;
  run_sweep(table, fresh, "");
  const MixtureFile want = read_mixture_file(fresh.output);
  CHECK(got.k == want.k);
  CHECK(got.means == want.means);
  CHECK(got.covariances == want.covariances);

  // Unchanged, the same partial run is resumed.
  fs::remove(f.output);
  CHECK_FALSE(run_sweep(table, f, "", stop_after(1)).complete);
  CHECK(run_sweep(table, f, "").resumed == 2);
}

TEST_CASE("the summary's sizes are the files' bytes: on disk and as their datasets store them", "[fit]") {
  Progress::set_enabled(false);
  const std::string table = mixture_table("sizes.h5", 5, 30, 60, [](std::size_t t) -> std::vector<Lobe> {
    if (t == 0) return {{1.0, 0.1, 0.5, 0.03, 0.0, 0.05}};
    return {{0.5, 0.1, 0.5, 0.03, 0.0, 0.05}, {0.3, -0.4, -2.0, 0.02, 0.0, 0.03}, {0.2, 0.5, 2.0, 0.02, 0.0, 0.03}};
  });
  FitSettings f = fit_settings("sizes");
  f.k_max = 4;
  const SweepSummary sum = run_sweep(table, f, "");
  CHECK(sum.mixture_file_bytes == fs::file_size(f.output));
  CHECK(sum.table_file_bytes == fs::file_size(table));
  CHECK(sum.table_bytes == 5u * 30u * 60u * 4u);
  CHECK(sum.table_slices == 5);
  CHECK(sum.symmetry_factor == 60);  // phi_o stands for as many directions as phi_i has cells

  // An independent reader: the storage HDF5 reports for each dataset of /mixture.
  const hid_t file = H5Fopen(f.output.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  REQUIRE(file >= 0);
  const hid_t group = H5Gopen2(file, "mixture", H5P_DEFAULT);
  std::uint64_t stored = 0;
  H5Literate(group, H5_INDEX_NAME, H5_ITER_NATIVE, nullptr,
              [](hid_t g, const char* name, const H5L_info_t*, void* acc) -> herr_t {
                const hid_t d = H5Dopen2(g, name, H5P_DEFAULT);
                if (d >= 0) {
                  *static_cast<std::uint64_t*>(acc) += H5Dget_storage_size(d);
                  H5Dclose(d);
                }
                return 0;
              },
              &stored);
  H5Gclose(group);
  H5Fclose(file);
  CHECK(sum.mixture_bytes == stored);
  const MixtureFile m = read_mixture_file(f.output);
  CHECK(m.payload_bytes() == stored);
  CHECK(m.kmax >= 3);  // padded: slice 0 holds fewer components than Kmax
  const std::string text = sum.text();
  CHECK_THAT(text, Catch::Contains("table            file "));
  CHECK_THAT(text, Catch::Contains("symmetry         azimuthal: one stored slice stands for 60 phi_o"));
}

TEST_CASE("fit_settings_match compares the recorded settings as typed values", "[fit][sweep]") {
  const FitSection f = fit_settings("match");
  CHECK(fit_settings_match(fit_settings_json(f), f));
  FitSection paths = f;  // the paths, the batch and the slices are not fit settings
  paths.output = "elsewhere.h5";
  paths.batch = 7;
  paths.theta_o = {0.5};
  CHECK(fit_settings_match(fit_settings_json(f), paths));
  // the record holds 9 significant digits: a setting beyond them matches as recorded
  FitSection fine = f;
  fine.k_penalty = 0.0040000000001;
  CHECK(fit_settings_match(fit_settings_json(fine), f));
  // the same values written otherwise (spacing, key order, 1e-07 as 0.0000001)
  std::string text = fit_settings_json(f);
  const std::string tol = "\"tolerance\": 1e-07";
  REQUIRE(text.find(tol) != std::string::npos);
  text.replace(text.find(tol), tol.size(), "\"tolerance\":   0.0000001");
  CHECK(fit_settings_match(text, f));
  // any recorded setting that differs
  std::vector<FitSection> other(8, f);
  other[0].k_max = 5;
  other[1].seed = 2;
  other[2].k_penalty = 0.005;
  other[3].error_target = 0.02;
  other[4].search = SearchStrategy::Restarts;
  other[5].refine = "none";
  other[6].rgb_copies.reset();
  other[7].final_iterations = 151;
  for (const FitSection& o : other) CHECK_FALSE(fit_settings_match(fit_settings_json(o), f));
  // not a record
  CHECK_FALSE(fit_settings_match("{}", f));
  CHECK_FALSE(fit_settings_match("not json: [", f));
  std::string criterion = fit_settings_json(f);
  criterion.replace(criterion.find("l1_rel + k_penalty * K"), 6, "loglik");
  CHECK_FALSE(fit_settings_match(criterion, f));
}

TEST_CASE("fit_slices_kept fits once, writes the sweep's outputs and serves any part of them", "[fit][sweep]") {
  Progress::set_enabled(false);
  const std::string table = mixture_table("kept.h5", 5, 30, 60, [](std::size_t t) -> std::vector<Lobe> {
    return {{1.0, -0.2 + 0.1 * double(t), 0.4, 0.03, 0.0, 0.06}};
  });
  FitSection f = fit_settings("kept");
  f.k_max = 3;
  for (const auto* out : {&f.output, &f.report, &f.search_report}) fs::remove(*out);
  const LoadedTable loaded = load_table(table);
  const TableSlices source(loaded.reader);
  const std::vector<SliceRef> all = plan_slices(source.meta(), {}, {});
  const std::vector<SliceRef> part(all.begin() + 1, all.begin() + 3);

  const MixtureFile fitted = fit_slices_kept(source, table, all, f, "", "test");
  CHECK(fitted.slices() == 5);
  const MixtureFile file = read_mixture_file(f.output);
  CHECK(file.weights == fitted.weights);
  CHECK(file.theta_o == fitted.theta_o);
  CHECK(fs::exists(f.report));
  CHECK(fs::exists(f.search_report));

  // From the file, fitting nothing (a device selector that selects none would fail a fit).
  const std::string none = "no-such-device";
  const MixtureFile again = fit_slices_kept(source, table, all, f, none, "test");
  CHECK(again.weights == fitted.weights);
  const MixtureFile sub = fit_slices_kept(source, table, part, f, none, "test");
  REQUIRE(sub.slices() == 2);
  CHECK(sub.theta_o == std::vector<double>{fitted.theta_o[1], fitted.theta_o[2]});
  CHECK(sub.k == std::vector<int>{fitted.k[1], fitted.k[2]});
  // Other settings are fitted anew.
  FitSection other = f;
  other.seed = 9;
  CHECK_THROWS_WITH(fit_slices_kept(source, table, part, other, none, "test"), Catch::Contains("no device matches"));
}
