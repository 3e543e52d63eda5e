// `bsdfmix compare` (host/compare/): the stand-in against its table at every table slice.
// A table made from a mixture's own stand-in compares to zero error and energy at the
// fitted slices and between them; the same mixture scaled by 1.1 has 10% more energy and
// 10% L1 in every channel; the albedos are the two integrals, at the slices and at any
// theta_o asked for; the CLI writes the CSV's exact header and fails with one line on a
// mismatched pair.
// labels: compare
#include <catch2/catch.hpp>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "compare/compare.hpp"
#include "core/domain.hpp"
#include "core/error.hpp"
#include "core/progress.hpp"
#include "io/mixture_file.hpp"
#include "io/table.hpp"

using namespace bsdfmix;
namespace fs = std::filesystem;

namespace {

fs::path temp_dir() {
  const fs::path d = fs::temp_directory_path() / "bsdfmix_compare_test";
  fs::create_directories(d);
  return d;
}

// A hemisphere mixture file fitted at theta_o slices 0 and 2 of a 3-slice grid: one lobe
// and a broad base per slice, `scale` times the slice's integral 1.
MixtureFile two_slice_mixture(double scale) {
  const TableMeta grid = make_grid(Domain::Hemisphere, 3, 1, 24, 48, true);
  MixtureFile m;
  m.domain = Domain::Hemisphere;
  m.azimuthal = true;
  m.table_theta_o = grid.theta_o;
  m.table_phi_o = grid.phi_o;
  for (std::size_t t : {std::size_t(0), std::size_t(2)}) {
    const double to = grid.theta_o[t];
    m.add_slice(to, 0.0, scale, 0.0, 0.0, {0.7, 0.3}, {to, 0.0, 0.6, 1.0}, {0.02, 0.0, 0.05, 0.3, 0.0, 2.0});
  }
  return m;
}

// The table whose every slice is the stand-in of `m` at its cell centers (grey rgb; with
// `noisy_blue`, blue is instead alternating +-0.01 around zero, as a noisy measurement).
std::string table_of(const MixtureFile& m, const std::string& name, bool noisy_blue = false) {
  TableMeta meta = make_grid(Domain::Hemisphere, 3, 1, 24, 48, true);
  meta.rgb = true;
  const mix::MixtureSet set = to_mixture_set(m);
  const std::string path = (temp_dir() / name).string();
  TableWriter w(path, meta);
  for (std::size_t t = 0; t < meta.theta_o.size(); ++t) {
    std::vector<float> v, rgb;
    for (double th : meta.theta_i)
      for (double ph : meta.phi_i) {
        v.push_back(float(set.eval_f(meta.theta_o[t], 0.0, th, ph)));
        for (int c = 0; c < 3; ++c) rgb.push_back(v.back());
        if (noisy_blue) rgb.back() = (v.size() % 2 ? 0.01f : -0.01f);
      }
    w.write_slice(t, 0, v.data(), rgb.data());
  }
  w.commit();
  return path;
}

}  // namespace

TEST_CASE("a table made of the stand-in compares to zero; a scaled stand-in by its scale", "[compare]") {
  Progress::set_enabled(false);
  const MixtureFile exact = two_slice_mixture(1.0);
  const std::string mixture = (temp_dir() / "exact.h5").string(), scaled = (temp_dir() / "scaled.h5").string();
  write_mixture_file(mixture, exact);
  write_mixture_file(scaled, two_slice_mixture(1.1));
  const std::string table = table_of(exact, "table.h5");

  const Comparison c = compare_stand_in(mixture, table);
  REQUIRE(c.rgb);
  REQUIRE(c.slices.size() == 3);
  CHECK(c.slices[0].fitted);
  CHECK_FALSE(c.slices[1].fitted);  // blended from slices 0 and 2
  CHECK(c.slices[2].fitted);
  for (const SliceComparison& s : c.slices) {
    INFO("slice " << s.slice);
    CHECK(s.l1 < 1e-6);          // float rounding of the table's cells
    CHECK(std::abs(s.energy) < 1e-6);
    CHECK(s.rgb_error < 1e-6);
    for (int q = 0; q < 3; ++q) CHECK(std::abs(s.energy_rgb[q]) < 1e-6);
  }
  const Comparison d = compare_stand_in(scaled, table);
  for (const SliceComparison& s : d.slices) {
    INFO("slice " << s.slice);
    CHECK(s.l1 == Approx(0.1).epsilon(1e-5));
    CHECK(s.energy == Approx(0.1).epsilon(1e-5));
    CHECK(s.rgb_error == Approx(0.1).epsilon(1e-5));
    for (int q = 0; q < 3; ++q) CHECK(s.l1_rgb[q] == Approx(0.1).epsilon(1e-5));
  }
  const std::string csv = comparison_csv(d);
  CHECK(csv.rfind("slice,theta_o,phi_o,fitted,l1_rel,l1_r,l1_g,l1_b,rgb_error,rgb_negative_share,energy,energy_r,"
                  "energy_g,energy_b,noise,albedo,albedo_stand_in\n", 0) == 0);
  CHECK_THAT(comparison_summary(d), Catch::Contains("between fitted (1 slices)"));
}

TEST_CASE("a channel of noise around zero is flagged and left out of the energy line", "[compare]") {
  Progress::set_enabled(false);
  const MixtureFile exact = two_slice_mixture(1.0);
  const std::string mixture = (temp_dir() / "noise.h5").string();
  write_mixture_file(mixture, exact);
  const Comparison c = compare_stand_in(mixture, table_of(exact, "noise_table.h5", true));
  for (const SliceComparison& s : c.slices) {
    INFO("slice " << s.slice);
    CHECK_FALSE(s.noise[0]);
    CHECK_FALSE(s.noise[1]);
    CHECK(s.noise[2]);
    CHECK(std::abs(s.energy_rgb[2]) > 1);  // the stand-in's blue is the luminance's: far off zero
    CHECK(s.negative_share > 0);
  }
  const std::string summary = comparison_summary(c);
  CHECK_THAT(summary, Catch::Contains("largest energy error 0.00% (B is noise around zero in 3 slices, not compared)"));
  CHECK_THAT(comparison_csv(c), Catch::Contains(",b,"));
  // the grey table: no channel flagged
  const Comparison grey = compare_stand_in(mixture, table_of(exact, "table.h5"));
  for (const SliceComparison& s : grey.slices) CHECK_FALSE(s.noise[2]);
  CHECK_THAT(comparison_summary(grey), !Catch::Contains("noise"));
}

TEST_CASE("the CLI writes the compare CSV and refuses a mismatched pair with one line", "[compare]") {
  const MixtureFile exact = two_slice_mixture(1.0);
  const std::string mixture = (temp_dir() / "cli.h5").string();
  write_mixture_file(mixture, exact);
  const std::string table = table_of(exact, "cli_table.h5");
  const std::string csv = (temp_dir() / "cli.csv").string(), err = (temp_dir() / "cli.err").string();
  fs::remove(csv);
  REQUIRE(std::system((std::string(BSDFMIX_BINARY) + " compare -q " + mixture + " " + table + " --csv " + csv +
                       " > /dev/null 2> " + err).c_str()) == 0);
  std::ifstream in(csv);
  std::string header;
  std::getline(in, header);
  CHECK(header == "slice,theta_o,phi_o,fitted,l1_rel,l1_r,l1_g,l1_b,rgb_error,rgb_negative_share,energy,energy_r,"
                  "energy_g,energy_b,noise,albedo,albedo_stand_in");
  // a fiber table against a hemisphere mixture
  TableMeta fiber = make_grid(Domain::Fiber, 3, 1, 8, 16, true);
  const std::string other = (temp_dir() / "fiber.h5").string();
  write_table(other, fiber, std::vector<float>(fiber.n_slices() * fiber.cells_per_slice(), 0.1f));
  const int rc = std::system((std::string(BSDFMIX_BINARY) + " compare -q " + mixture + " " + other + " 2> " + err).c_str());
  CHECK(rc != 0);
  std::ifstream e(err);
  std::stringstream ss;
  ss << e.rdbuf();
  const std::string msg = ss.str();
  CHECK_THAT(msg, Catch::Contains("hemisphere") && Catch::Contains(other));
  CHECK(std::count(msg.begin(), msg.end(), '\n') == 1);
}

TEST_CASE("compare gives both albedos per slice and at any theta_o", "[compare]") {
  const MixtureFile exact = two_slice_mixture(1.0);
  const std::string mixture = (temp_dir() / "albedo.h5").string();
  write_mixture_file(mixture, exact);
  const std::string table = table_of(exact, "albedo_table.h5");
  const TableMeta grid = make_grid(Domain::Hemisphere, 3, 1, 24, 48, true);
  // between rows 0 and 1, a quarter of the way; beyond the last row; on row 2
  const double between = grid.theta_o[0] + 0.25 * (grid.theta_o[1] - grid.theta_o[0]);
  const Comparison c = compare_stand_in(mixture, table, {between, 1.5, grid.theta_o[2]});
  REQUIRE(c.slices.size() == 3);
  const std::vector<float> ones(grid.cells_per_slice(), 1.f);
  const std::vector<double> g = integrand_weights(grid.domain, grid.theta_i, grid.phi_i, ones.data());
  const mix::MixtureSet set = to_mixture_set(exact);
  for (const SliceComparison& r : c.slices) {
    double a = 0;  // the table is the stand-in at the cell centers: one integral for both
    for (std::size_t i = 0; i < grid.theta_i.size(); ++i)
      for (std::size_t j = 0; j < grid.phi_i.size(); ++j)
        a += g[i * grid.phi_i.size() + j] * double(float(set.eval_f(r.theta_o, 0, grid.theta_i[i], grid.phi_i[j])));
    CHECK(r.albedo == Approx(a).epsilon(1e-9));
    CHECK(r.albedo_stand_in == Approx(a).epsilon(1e-6));
    CHECK(r.albedo > 0.3);
  }
  REQUIRE(c.asked.size() == 3);
  CHECK(c.asked[0].row_lo == 0);
  CHECK(c.asked[0].row_hi == 1);
  CHECK(c.asked[0].table == Approx(0.75 * c.slices[0].albedo + 0.25 * c.slices[1].albedo));
  CHECK(c.asked[1].row_lo == 2);
  CHECK(c.asked[1].row_hi == 2);
  CHECK(c.asked[1].table == Approx(c.slices[2].albedo));
  CHECK(c.asked[2].table == Approx(c.slices[2].albedo));
  CHECK(c.asked[2].stand_in == Approx(c.slices[2].albedo_stand_in));
  // the stand-in between slices is the blend a renderer evaluates, not the table's interpolation
  double a = 0;
  for (std::size_t i = 0; i < grid.theta_i.size(); ++i)
    for (std::size_t j = 0; j < grid.phi_i.size(); ++j)
      a += g[i * grid.phi_i.size() + j] * set.eval_f(between, 0, grid.theta_i[i], grid.phi_i[j]);
  CHECK(c.asked[0].stand_in == Approx(a));
  const std::string summary = comparison_summary(c);
  CHECK_THAT(summary, Catch::Contains("albedo (integral of f cos theta_i d omega_i): table "));
  CHECK_THAT(summary, Catch::Contains("albedo at theta_o 85.94 deg: table") && Catch::Contains("its nearest row"));
  CHECK_THROWS_WITH(compare_stand_in(mixture, table, {1.6}), Catch::Contains("outside the hemisphere domain"));

  // a table of f = (row + 1) / pi: albedo row + 1 (the midpoint rule on 24 x 48 cells),
  // interpolated linearly between rows
  std::vector<float> lambert;
  for (std::size_t t = 0; t < 3; ++t)
    for (std::size_t k = 0; k < grid.cells_per_slice(); ++k) lambert.push_back(float(double(t + 1) / kPi));
  write_table((temp_dir() / "lambert.h5").string(), grid, lambert);
  const Comparison l = compare_stand_in(mixture, (temp_dir() / "lambert.h5").string(), {between});
  for (std::size_t t = 0; t < 3; ++t) CHECK(l.slices[t].albedo == Approx(double(t + 1)).epsilon(2e-3));
  CHECK(l.asked[0].table == Approx(1.25).epsilon(2e-3));
  // the scaled stand-in's albedo: its scale
  write_mixture_file((temp_dir() / "albedo_scaled.h5").string(), two_slice_mixture(1.1));
  const Comparison d = compare_stand_in((temp_dir() / "albedo_scaled.h5").string(), table);
  for (std::size_t s = 0; s < 3; ++s) CHECK(d.slices[s].albedo_stand_in == Approx(1.1 * c.slices[s].albedo_stand_in));
}
