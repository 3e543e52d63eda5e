// fit.map auto (sweep/map_choice.hpp): the probe's slices, its record, and the choice on a
// table the disk fits better and on one (theta, phi) fits better, through the file sweep.
#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>

#include "io/mixture_file.hpp"
#include "io/table.hpp"
#include "sweep/slice_source.hpp"
#include "sweep/map_choice.hpp"
#include "sweep/sweep.hpp"

using namespace bsdfmix;
namespace fs = std::filesystem;

namespace {

fs::path temp_dir() {
  const fs::path d = fs::temp_directory_path() / "bsdfmix_map_choice_test";
  fs::create_directories(d);
  return d;
}

std::vector<SliceRef> plan_of(std::size_t n) {
  std::vector<SliceRef> p;
  for (std::size_t i = 0; i < n; ++i) p.push_back({i, i, 0});
  return p;
}

// A hemisphere table of `rows` slices of 24 x 48 cells with f(theta_i, phi_i) from `f`.
template <class F>
std::string hemisphere_table(const std::string& name, std::size_t rows, F f) {
  TableMeta m = make_grid(Domain::Hemisphere, rows, 1, 24, 48, true);
  m.source = R"({"model": "map choice test"})";
  std::vector<float> v;
  for (std::size_t t = 0; t < rows; ++t)
    for (double ti : m.theta_i)
      for (double pi : m.phi_i) v.push_back(float(f(m.theta_o[t], ti, pi)));
  const std::string path = (temp_dir() / name).string();
  write_table(path, m, v);
  return path;
}

FitSettings auto_settings(const std::string& stem) {
  FitSettings f;  // map: auto, the default
  f.output = (temp_dir() / (stem + "_mixture.h5")).string();
  f.report = (temp_dir() / (stem + "_fit.csv")).string();
  f.search_report = (temp_dir() / (stem + "_search.csv")).string();
  f.k_min = 1;
  f.k_max = 3;
  f.restarts = 1;
  f.final_restarts = 2;
  f.iterations = 40;
  f.final_iterations = 80;
  f.refine_evaluations = 30;
  f.batch = 2;
  return f;
}

}  // namespace

TEST_CASE("the probe takes kProbeSlices of a plan, spread, first and last; a small plan whole", "[fit]") {
  const std::vector<SliceRef> p = probe_slices(plan_of(90));
  REQUIRE(p.size() == kProbeSlices);
  CHECK(p.front().index == 0);
  CHECK(p.back().index == 89);
  for (std::size_t i = 1; i < p.size(); ++i) {
    CHECK(p[i].index > p[i - 1].index);
    CHECK(p[i].index - p[i - 1].index >= 9);
    CHECK(p[i].index - p[i - 1].index <= 10);
  }
  CHECK(probe_slices(plan_of(7)).size() == 7);
  CHECK(probe_slices(plan_of(kProbeSlices)).size() == kProbeSlices);
}

TEST_CASE("auto probes on the hemisphere only; a set map is kept", "[fit]") {
  FitSettings f;
  CHECK(f.map == "auto");
  CHECK(map_probed(f, Domain::Hemisphere));
  CHECK_FALSE(map_probed(f, Domain::Fiber));
  CHECK(map_without_probe(f, Domain::Fiber) == "theta_phi");
  CHECK(map_without_probe(f, Domain::Hemisphere) == "equal_area");
  f.map = "theta_phi";
  CHECK_FALSE(map_probed(f, Domain::Hemisphere));
  CHECK(map_without_probe(f, Domain::Hemisphere) == "theta_phi");
}

TEST_CASE("a kept choice reads back under its key only", "[fit]") {
  MapChoice c;
  c.map = "theta_phi";
  c.probed = 10;
  c.l1_theta_phi = 0.0123456789;
  c.l1_equal_area = 0.0234567891;
  c.seconds = 12.5;
  const std::string r = map_choice_record(c, "abc123");
  const std::optional<MapChoice> back = read_map_choice(r, "abc123");
  REQUIRE(back);
  CHECK(back->map == "theta_phi");
  CHECK(back->probed == 10);
  CHECK(back->l1_theta_phi == c.l1_theta_phi);
  CHECK(back->l1_equal_area == c.l1_equal_area);
  CHECK(back->text() == c.text());
  CHECK_FALSE(read_map_choice(r, "abc124"));
  CHECK_FALSE(read_map_choice(r.substr(0, r.size() - 8), "abc123"));
  CHECK_FALSE(read_map_choice("bsdfmix map choice\nabc123\nplane 10 0.1 0.2 1\n", "abc123"));
}

// A diffuse floor under a lobe near the pole: the disk's base takes the floor. A narrow
// ring of constant theta_i: a line in (theta, phi), a circle on the disk.
TEST_CASE("fit.map auto chooses the disk for a diffuse table and (theta, phi) for a ring", "[fit]") {
  const std::size_t rows = 14;  // more than kProbeSlices: the choice is kept while the fit runs
  const std::string diffuse = hemisphere_table("diffuse.h5", rows, [](double to, double ti, double pi) {
    const double dt = ti - 0.5 * to, dp = pi;
    return 0.3 + 4.0 * std::exp(-(dt * dt + dp * dp) / (2 * 0.15 * 0.15));
  });
  const std::string ring = hemisphere_table("ring.h5", rows, [](double to, double ti, double) {
    const double dt = ti - (0.9 + 0.2 * to);
    return std::exp(-dt * dt / (2 * 0.04 * 0.04));
  });
  struct Case {
    std::string table, stem, map, plane;
  };
  for (const Case& c : {Case{diffuse, "diffuse", "equal_area", "disk"}, Case{ring, "ring", "theta_phi", "theta_phi"}}) {
    CAPTURE(c.stem);
    const FitSettings f = auto_settings(c.stem);
    SweepOptions stop;
    stop.max_batches = 1;
    const SweepSummary partial = run_sweep(c.table, f, "", stop);
    REQUIRE_FALSE(partial.complete);
    REQUIRE(fs::exists(f.output + ".map"));  // the choice, kept for the resumed run
    const SweepSummary s = run_sweep(c.table, f, "");
    CHECK_FALSE(fs::exists(f.output + ".map"));
    CHECK(s.resumed == 2);
    CHECK(s.map.find(c.map == "equal_area" ? "the equal-area disk, by a probe of 10" : "(theta, phi), by a probe of 10") == 0);
    const MixtureFile m = read_mixture_file(f.output);
    CHECK(map_name(m.map) == c.plane);
    CHECK(m.fit_settings.find("\"map\": \"auto\"") != std::string::npos);
  }
}

// A plan the probe covers whole: its fits in the chosen map are the result, in the file
// sweep and in memory alike, with no second fit and no choice kept.
TEST_CASE("a plan of kProbeSlices or fewer is the probe's own fit", "[fit]") {
  const std::string ring = hemisphere_table("ring6.h5", 6, [](double to, double ti, double) {
    const double dt = ti - (0.9 + 0.2 * to);
    return std::exp(-dt * dt / (2 * 0.04 * 0.04));
  });
  const FitSettings f = auto_settings("ring6");
  const SweepSummary s = run_sweep(ring, f, "");
  CHECK(s.map.find("(theta, phi), by a probe of 6 slice(s)") == 0);
  CHECK_FALSE(fs::exists(f.output + ".map"));
  const MixtureFile file = read_mixture_file(f.output);
  CHECK(file.map == mix::Map::ThetaPhi);
  CHECK(file.slices() == 6);

  TableReader reader(ring);
  const TableSlices source(reader);
  const SweepResult memory = fit_slices(source, plan_slices(reader.meta(), {}, {}), f, select_devices(""), "in memory");
  CHECK(memory.mixture.map == mix::Map::ThetaPhi);
  CHECK(memory.mixture.fit_settings == file.fit_settings);
  REQUIRE(memory.mixture.slices() == 6);
  CHECK(memory.mixture.k == file.k);
  CHECK(memory.mixture.l1_rel == file.l1_rel);
}
