// The stand-in a renderer gets from a mixture file (docs/formats.md, "Mixture file";
// docs/fitting.md, "Colour and energy"): its energy kept per channel where a lobe leaks past
// the theta border, a grey table's rgb_scale equal to scale times the weights, the report's
// errors equal to an independent recomputation from the file through the header, files
// written before colour still read, the file's rgb_scale checked and round-tripped, and the
// channels moving the Gaussians on a measured material.
// labels: fit
#include <catch2/catch.hpp>

#include "csv_rows.hpp"

#include <hdf5.h>

#include <cmath>
#include <filesystem>

#include "core/error.hpp"
#include "core/progress.hpp"
#include "device/device.hpp"
#include "fit/amplitudes.hpp"
#include "fit/gmm.hpp"
#include "io/mixture_file.hpp"
#include "io/table.hpp"
#include "sweep/base_lobe.hpp"
#include "sweep/fit_error.hpp"
#include "sweep/fit_slices.hpp"
#include "sweep/slice_plan.hpp"
#include "sweep/slice_source.hpp"
#include "sweep/sweep.hpp"
#include "tables/rgl_import.hpp"

using namespace bsdfmix;
using bsdfmix::test::csv_rows;
namespace fs = std::filesystem;

namespace {

fs::path temp_dir() {
  const fs::path d = fs::temp_directory_path() / "bsdfmix_stand_in_test";
  fs::create_directories(d);
  return d;
}

struct Lobe {
  double w, mt, mp, st, sp, rho;
  double rgb[3];
};

// A hemisphere table of `n_to` slices whose integrand (f cos J) is the mixture of
// `lobes(t)`: `values` the luminance mixture, `rgb` each lobe times its colour; with
// `grey`, rgb = values in every channel.
template <class Lobes>
std::string colour_table(const std::string& name, std::size_t n_to, std::size_t nt, std::size_t np, Lobes lobes,
                         bool grey = false) {
  TableMeta m = make_grid(Domain::Hemisphere, n_to, 1, nt, np, true);
  m.source = R"({"model": "stand-in test"})";
  m.rgb = true;
  const std::string path = (temp_dir() / name).string();
  TableWriter out(path, m);
  for (std::size_t t = 0; t < n_to; ++t) {
    std::vector<mix::SliceMixture> parts;
    std::vector<Lobe> ls = lobes(t);
    for (const Lobe& l : ls)
      parts.push_back(make_slice_mixture({1.0}, {l.mt, l.mp}, {l.st * l.st, l.rho * l.st * l.sp, l.sp * l.sp}));
    std::vector<float> v(nt * np), rgb(3 * nt * np);
    for (std::size_t i = 0; i < nt; ++i)
      for (std::size_t j = 0; j < np; ++j) {
        const double jc = std::cos(m.theta_i[i]) * std::sin(m.theta_i[i]);
        double y = 0, c[3] = {0, 0, 0};
        for (std::size_t k = 0; k < ls.size(); ++k) {
          const double d = ls[k].w * parts[k].pdf_param(m.theta_i[i], m.phi_i[j]) / jc;
          y += d;
          for (int q = 0; q < 3; ++q) c[q] += d * ls[k].rgb[q];
        }
        v[i * np + j] = float(y);
        for (int q = 0; q < 3; ++q) rgb[3 * (i * np + j) + q] = grey ? float(y) : float(c[q]);
      }
    out.write_slice(t, 0, v.data(), rgb.data());
  }
  out.commit();
  return path;
}

FitSettings settings(const std::string& stem) {
  FitSettings f;
  f.map = "theta_phi";  // the tables are Gaussians in (theta, phi): their true K is known there
  f.output = (temp_dir() / (stem + "_mixture.h5")).string();
  f.report = (temp_dir() / (stem + "_fit.csv")).string();
  f.search_report = (temp_dir() / (stem + "_search.csv")).string();
  f.k_min = 1;
  f.k_max = 5;
  f.restarts = 2;
  f.final_restarts = 2;
  f.iterations = 60;
  f.final_iterations = 150;
  f.search_pool = 1;
  return f;
}

// The table's integrand weights of slice t: luminance and R, G, B (channel-major).
struct SliceWeights {
  std::vector<double> y, rgb;
};
SliceWeights read_weights(const std::string& table, std::size_t t) {
  const TableReader reader(table);
  const TableSlices slices(reader);
  const SliceRef ref{t, t, 0};
  return {slices.weights(ref), slices.rgb_weights(ref)};
}

// The lobes of the leak test: one centred 0.06 rad above the border at theta = 0 (a third
// of it below), red; two inside, of other colours.
std::vector<Lobe> leaking(std::size_t t) {
  return {{0.45, 0.06, 0.3 * double(t), 0.14, 0.5, 0.1, {0.9, 0.3, 0.1}},
          {0.35, 0.8, 2.0, 0.15, 0.6, 0.0, {0.2, 0.7, 0.4}},
          {0.2, 1.1, -2.0, 0.12, 0.4, -0.2, {0.3, 0.3, 0.9}}};
}

}  // namespace

TEST_CASE("a lobe leaking past the theta border keeps the stand-in's energy in every channel", "[stand_in]") {
  Progress::set_enabled(false);
  const std::string table = colour_table("leak.h5", 3, 45, 90, leaking);
  FitSettings f = settings("leak");
  f.k_min = f.k_max = 3;  // the true K: one Gaussian draws the cut lobe, and leaks
  run_sweep(table, f, "");
  const MixtureFile m = read_mixture_file(f.output);
  REQUIRE(m.has_rgb());
  const mix::MixtureSet set = to_mixture_set(m);
  const TableReader reader(table);
  const TableMeta& meta = reader.meta();
  const double area = axis_step(meta.theta_i) * axis_step(meta.phi_i);
  for (std::size_t s = 0; s < m.slices(); ++s) {
    INFO("slice " << s);
    const SliceWeights w = read_weights(table, s);
    const std::size_t n = w.y.size();
    double table_e[4] = {0, 0, 0, 0};
    for (std::size_t i = 0; i < n; ++i) {
      table_e[0] += w.y[i];
      for (int c = 0; c < 3; ++c) table_e[c + 1] += w.rgb[std::size_t(c) * n + i];
    }
    // The stand-in's in-domain integral, closed form: every component's in-domain mass
    // times its amplitude (scale * weight for the luminance, rgb_scale per channel, or the
    // colour copies' amplitudes where the slice has them).
    const mix::SliceMixture& sm = set.slices[s];
    double e[4] = {0, 0, 0, 0}, fitted_mass = 0;
    for (const auto& g : sm.components) {
      const double z = in_domain_mass(Domain::Hemisphere, g.mu_t, g.s_tt);
      e[0] += sm.scale * g.weight * z;
      fitted_mass += g.weight * z;
      if (sm.colour.empty())
        for (int c = 0; c < 3; ++c) e[c + 1] += g.rgb[c] * z;
    }
    for (const auto& g : sm.colour)
      for (int c = 0; c < 3; ++c) e[c + 1] += g.rgb[c] * in_domain_mass(Domain::Hemisphere, g.mu_t, g.s_tt);
    CHECK(fitted_mass < 0.97);  // the fitted Gaussians leak: scale = the cells' sum would lose > 3%
    // The same by the header at the cell centers (what a renderer's quadrature sees).
    double q[4] = {0, 0, 0, 0};
    const std::size_t np = meta.phi_i.size();
    for (std::size_t i = 0; i < n; ++i) {
      const double th = meta.theta_i[i / np], ph = meta.phi_i[i % np], jc = std::cos(th) * std::sin(th) * area;
      double rgb[3];
      set.eval_rgb(sm.theta_o, 0.0, th, ph, rgb);
      q[0] += set.eval_f(sm.theta_o, 0.0, th, ph) * jc;
      for (int c = 0; c < 3; ++c) q[c + 1] += rgb[c] * jc;
    }
    for (int c = 0; c < 4; ++c) {
      INFO("channel " << c << ": table " << table_e[c] << ", stand-in " << e[c] << ", at the cell centers " << q[c]);
      CHECK(std::abs(e[c] / table_e[c] - 1) < 1e-6);
      CHECK(std::abs(q[c] / table_e[c] - 1) < 0.005);
    }
  }
}

TEST_CASE("a grey table gives rgb_scale = scale * weight in every channel", "[stand_in]") {
  Progress::set_enabled(false);
  const std::string table = colour_table("grey.h5", 3, 45, 90, leaking, true);
  const FitSettings f = settings("grey");
  run_sweep(table, f, "");
  const MixtureFile m = read_mixture_file(f.output);
  REQUIRE(m.has_rgb());
  const std::size_t K = std::size_t(m.kmax);
  for (std::size_t s = 0; s < m.slices(); ++s)
    for (int j = 0; j < m.k[s]; ++j)
      for (int c = 0; c < 3; ++c) {
        const double lum = m.scale[s] * double(m.weights[s * K + std::size_t(j)]);
        INFO("slice " << s << " component " << j << " channel " << c);
        CHECK(m.rgb_scale[(s * K + std::size_t(j)) * 3 + std::size_t(c)] == Approx(lum).epsilon(2e-7).margin(1e-300));
      }
  // And the report's RGB error is the luminance error: the same stand-in in every channel.
  const auto rows = csv_rows(f.report);
  REQUIRE(rows.size() == m.slices() + 1);
  for (std::size_t r = 1; r < rows.size(); ++r) {
    const std::vector<std::string>& row = rows[r];
    REQUIRE(row.size() == 14);
    CHECK(std::stod(row[10]) == Approx(std::stod(row[6])).epsilon(1e-6));
    CHECK(std::stod(row[11]) == 0.0);
  }
}

TEST_CASE("the report's errors are the stand-in's through the header, recomputed from the file", "[stand_in]") {
  Progress::set_enabled(false);
  const std::string table = colour_table("recompute.h5", 4, 45, 90, [](std::size_t t) {
    std::vector<Lobe> l = leaking(t);
    l[2].rgb[2] = -0.05;  // a channel that dips below zero: measured noise a stand-in cannot follow
    return l;
  });
  const FitSettings f = settings("recompute");
  run_sweep(table, f, "");
  const MixtureFile m = read_mixture_file(f.output);
  const mix::MixtureSet set = to_mixture_set(m);
  const auto rows = csv_rows(f.report);
  REQUIRE(rows.size() == m.slices() + 1);
  CHECK(rows[0] == std::vector<std::string>{"slice", "theta_o", "phi_o", "k", "iterations", "loglik", "l1_rel", "seconds",
                                            "device", "status", "rgb_l1_rel", "rgb_negative", "defensive", "max_weight"});
  const TableReader reader(table);
  const TableMeta& meta = reader.meta();
  const std::size_t np = meta.phi_i.size();
  const double area = axis_step(meta.theta_i) * axis_step(meta.phi_i);
  bool some_negative = false;
  for (std::size_t s = 0; s < m.slices(); ++s) {
    INFO("slice " << s);
    const SliceWeights w = read_weights(table, s);
    const std::size_t n = w.y.size();
    // The refined components are at least half a cell wide (fit/gmm.hpp sub_cell), so every
    // cell's luminance is the header's value at its center; colour copies may be narrower
    // (0.875 times a component's covariance), and such a copy's cell mass is its mean over
    // 3 x 3 points of the cell, the rule of the report (docs/formats.md).
    const double dth = axis_step(meta.theta_i), dph = axis_step(meta.phi_i);
    for (const auto& g : set.slices[s].components) REQUIRE_FALSE(sub_cell(g.s_tt, g.s_tp, g.s_pp, dth, dph));
    const mix::SliceMixture& sm = set.slices[s];
    // The renderer's view: eval_f and eval_rgb at the cell centers (or the copies' rule), as
    // integrand weights.
    double y = 0, ye = 0, a = 0, ae = 0, ne = 0;
    for (std::size_t i = 0; i < n; ++i) {
      const double th = meta.theta_i[i / np], ph = meta.phi_i[i % np], jc = std::cos(th) * std::sin(th) * area;
      double rgb[3] = {0, 0, 0};
      set.eval_rgb(m.theta_o[s], 0.0, th, ph, rgb);
      if (!sm.colour.empty()) {
        rgb[0] = rgb[1] = rgb[2] = 0;
        for (const auto& g : sm.colour) {
          double d = 0;
          const int r = sub_cell(g.s_tt, g.s_tp, g.s_pp, dth, dph) ? 1 : 0;
          for (int u = -r; u <= r; ++u)
            for (int v = -r; v <= r; ++v) d += g.density(th + u * dth / 3, wrap_phi(ph + v * dph / 3));
          for (int c = 0; c < 3; ++c) rgb[c] += g.rgb[c] * d / (r ? 9.0 : 1.0) / (std::cos(th) * std::sin(th));
        }
      }
      y += w.y[i];
      ye += std::abs(w.y[i] - set.eval_f(m.theta_o[s], 0.0, th, ph) * jc);
      for (int c = 0; c < 3; ++c) {
        const double x = w.rgb[std::size_t(c) * n + i], d = std::abs(x - rgb[c] * jc);
        a += std::abs(x);
        ae += d;
        if (x < 0) ne += d;
      }
    }
    const double reported = std::stod(rows[s + 1][6]), rgb_reported = std::stod(rows[s + 1][10]),
                 neg_reported = std::stod(rows[s + 1][11]);
    CHECK(std::abs(reported - ye / y) < 0.002);  // 0.2 points, the contract; in fact to rounding:
    CHECK(reported == Approx(ye / y).epsilon(1e-6));
    CHECK(m.l1_rel[s] == Approx(ye / y).epsilon(1e-6));
    CHECK(rgb_reported == Approx(ae / a).epsilon(1e-6));
    CHECK(neg_reported == Approx(ne / a).epsilon(1e-6).margin(1e-12));
    some_negative = some_negative || ne > 0;
    CHECK(neg_reported < rgb_reported);
  }
  CHECK(some_negative);
}

TEST_CASE("a mixture file written before colour still reads, and its stand-in is grey", "[stand_in]") {
  const MixtureFile m = read_mixture_file(std::string(BSDFMIX_TEST_DATA) + "/mixture_before_rgb.h5");
  REQUIRE(m.slices() == 3);
  CHECK_FALSE(m.has_rgb());
  CHECK(m.rgb_scale.empty());
  const mix::MixtureSet set = to_mixture_set(m);
  for (const auto& s : set.slices) CHECK_FALSE(s.has_rgb);
  for (const double to : {0.3, 0.9})
    for (const double t : {0.2, 0.7, 1.3}) {
      double rgb[3];
      set.eval_rgb(to, 0.0, t, 0.5, rgb);
      const double f = set.eval_f(to, 0.0, t, 0.5);
      CHECK(f > 0);
      for (double c : rgb) CHECK(c == f);
    }
  // Written again, it stays without rgb_scale.
  const std::string again = (temp_dir() / "before_rgb_again.h5").string();
  write_mixture_file(again, m);
  CHECK_FALSE(read_mixture_file(again).has_rgb());
}

TEST_CASE("rgb_scale round-trips and is checked on read", "[stand_in]") {
  MixtureFile m;
  m.domain = Domain::Hemisphere;
  m.table_theta_o = {0.1, 0.2};
  m.table_phi_o = {0.0};
  const std::vector<double> rgb1 = {0.1, 0.2, 0.3}, rgb2 = {0.4, 0.5, 0.6, 0.7, 0.8, 0.9};
  m.add_slice(0.1, 0, 1.0, -1, 0.1, {1.0}, {0.5, 0.0}, {0.1, 0.0, 0.2}, &rgb1);
  m.add_slice(0.2, 0, 2.0, -1, 0.1, {0.5, 0.5}, {0.5, 0.0, 0.7, 1.0}, {0.1, 0.0, 0.2, 0.1, 0.01, 0.2}, &rgb2);
  CHECK(m.kmax == 2);
  CHECK(m.rgb_scale == std::vector<double>{0.1, 0.2, 0.3, 0, 0, 0, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9});
  CHECK(m.slice_rgb(1) == rgb2);
  CHECK_THROWS_AS(m.add_slice(0.3, 0, 1.0, -1, 0.1, {1.0}, {0.5, 0.0}, {0.1, 0.0, 0.2}), Error);  // all or none
  const std::string path = (temp_dir() / "rgb_roundtrip.h5").string();
  write_mixture_file(path, m);
  const MixtureFile r = read_mixture_file(path);
  CHECK(r.rgb_scale == m.rgb_scale);
  const mix::MixtureSet set = to_mixture_set(r);
  CHECK(set.slices[1].has_rgb);
  CHECK(set.slices[1].components[1].rgb[2] == 0.9);
  CHECK(r.payload_bytes() == m.payload_bytes());

  // A negative amplitude and a wrong shape are refused, naming the dataset.
  MixtureFile bad = m;
  bad.rgb_scale[7] = -0.5;
  write_mixture_file(path, bad);
  CHECK_THROWS_WITH(read_mixture_file(path), Catch::Contains("rgb_scale is not a finite non-negative number"));
  {
    write_mixture_file(path, m);
    const hid_t file = H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    H5Ldelete(file, "/mixture/rgb_scale", H5P_DEFAULT);
    const hsize_t dims[2] = {2, 6};
    const hid_t space = H5Screate_simple(2, dims, nullptr);
    const hid_t d = H5Dcreate2(file, "/mixture/rgb_scale", H5T_IEEE_F64LE, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    H5Dwrite(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, m.rgb_scale.data());
    H5Dclose(d);
    H5Sclose(space);
    H5Fclose(file);
  }
  CHECK_THROWS_WITH(read_mixture_file(path), Catch::Contains("rgb_scale: expected shape [S, Kmax, 3]"));
}

TEST_CASE("the channels move the Gaussians: a lower RGB error on a measured material", "[stand_in]") {
  Progress::set_enabled(false);
  // cg_sunflower (data/rgl/): yellow, its faint blue lobe and its red and green of other
  // shapes than their luminance; 10 slices of 45 x 90 cells.
  RglImportOptions opt;
  opt.file = std::string(BSDFMIX_SOURCE_DIR) + "/data/rgl/cg_sunflower_rgb.bsdf";
  opt.n_theta_o = 10;
  opt.n_theta_i = 45;
  opt.n_phi_i = 90;
  const std::string table = (temp_dir() / "sunflower.h5").string();
  import_rgl_table(opt, table);
  double sums[2][2] = {{0, 0}, {0, 0}};  // [luminance alone / with the channels][luminance L1, RGB error]
  for (int with : {0, 1}) {
    FitSettings f;
    const std::string stem = with ? "sunflower_rgb" : "sunflower_y";
    f.output = (temp_dir() / (stem + "_mixture.h5")).string();
    f.report = (temp_dir() / (stem + "_fit.csv")).string();
    f.search_report = (temp_dir() / (stem + "_search.csv")).string();
    f.k_max = 16;
    f.map = "theta_phi";  // measured in (theta, phi); on the disk the channels gain 2% here
    f.refine_rgb = with ? 0.5 : 0.0;
    f.rgb_copies.reset();  // the components' colour alone: the refinement's effect on it
    run_sweep(table, f, "");
    const auto rows = csv_rows(f.report);
    REQUIRE(rows.size() == 11);
    for (std::size_t r = 1; r < rows.size(); ++r) {
      sums[with][0] += std::stod(rows[r][6]);
      sums[with][1] += std::stod(rows[r][10]) - std::stod(rows[r][11]);  // less the negative cells' part
    }
  }
  INFO("summed over the slices: luminance L1 " << sums[0][0] << " alone, " << sums[1][0]
                                               << " with the channels; RGB error less its negative part "
                                               << sums[0][1] << " and " << sums[1][1]);
  CHECK(sums[1][1] < 0.97 * sums[0][1]);
  CHECK(sums[1][0] < 1.03 * sums[0][0]);
}

TEST_CASE("the Lambertian base: a diffuse floor under a lobe is found and taken off", "[stand_in]") {
  // f = rho / pi everywhere plus a lobe on 45 x 90 hemisphere cells; then the lobe alone.
  const std::vector<double> theta = uniform_centers(0.0, kPi / 2, 45), phi = uniform_centers(-kPi, kPi, 90);
  const double dt = theta[1] - theta[0], dp = phi[1] - phi[0], rho = 0.3;
  for (const double floor : {rho, 0.0}) {
    INFO("floor " << floor);
    std::vector<double> w, lobe;
    for (double t : theta)
      for (double p : phi) {
        const double l = 4.0 * std::exp(-((t - 0.5) * (t - 0.5) + p * p) / (2 * 0.1 * 0.1));
        const double cell = std::cos(t) * std::sin(t) * dt * dp;
        w.push_back((floor / kPi + l) * cell);
        lobe.push_back(l * cell);
      }
    std::vector<double> rgb(3 * w.size());
    for (int c = 0; c < 3; ++c) std::copy(w.begin(), w.end(), rgb.begin() + long(c * w.size()));
    const SliceBase b = take_base(theta, phi.size(), dt, dp, w, &rgb);
    CHECK(b.lum == Approx(floor).margin(1e-9));  // the floor, where the lobe is not
    for (int c = 0; c < 3; ++c) CHECK(b.rgb[c] == Approx(floor).margin(1e-9));
    CHECK(b.excess < 1e-12);
    double left = 0, want = 0;
    for (std::size_t i = 0; i < w.size(); ++i) left += w[i], want += lobe[i];
    CHECK(left == Approx(want).epsilon(1e-9));  // what is left is the lobe
  }
}
