// Colour copies (include/bsdfmix/mixture.hpp copy_of, host/sweep/stand_in.*; docs/fitting.md,
// "Colour copies"): the copies keep their component's moments; the amplitudes of a known
// mixture of copies are recovered exactly by the reference and the kernel; a slice whose
// colour changes across a lobe gets copies, a lower RGB error, each channel's energy kept,
// and the header evaluates the file exactly as the fit did; the file round-trips in every
// storage and is checked on read; blending mixes slices with and without copies.
// labels: fit
#include <catch2/catch.hpp>

#include <hdf5.h>

#include <cmath>
#include <filesystem>
#include <memory>

#include "core/domain.hpp"
#include "core/error.hpp"
#include "device/device.hpp"
#include "fit/amplitudes.hpp"
#include "fit/em.hpp"
#include "io/mixture_file.hpp"
#include "sweep/fit_error.hpp"
#include "sweep/stand_in.hpp"

using namespace bsdfmix;
namespace fs = std::filesystem;

namespace {

void add(Gmm& g, double w, double mt, double mp, double st, double sp, double rho) {
  g.weight.push_back(w);
  g.mean.insert(g.mean.end(), {mt, mp});
  g.cov.insert(g.cov.end(), {st * st, rho * st * sp, sp * sp});
}

EmEngine& device() {
  static EmEngine e(select_devices(""), 1, EmPrecision::Auto);
  return e;
}

// Two lobes inside the hemisphere, one near the border at theta = pi/2; their means and
// covariances float32 numbers, as a mixture file stores them (colour_copies' input).
Gmm lobes() {
  Gmm g;
  add(g, 0.6, 0.5, 0.4, 0.12, 0.35, 0.3);
  add(g, 0.4, 1.3, -2.0, 0.1, 0.5, -0.2);
  for (double& x : g.mean) x = float(x);
  for (double& x : g.cov) x = float(x);
  return g;
}

// The integrand weights of channel `c` at every cell: each lobe's luminance times a colour
// that changes across it (linear in its own theta, blue rising where red falls), so that one
// amplitude per lobe and channel cannot follow it.
std::vector<double> tilted(const SliceGrid& grid, const Gmm& g, bool luminance_only) {
  const std::size_t n = grid.cells(), np = grid.phi.size();
  const double area = axis_step(grid.theta) * axis_step(grid.phi);
  const mix::SliceMixture m = make_slice_mixture(g.weight, g.mean, g.cov);
  std::vector<double> out(luminance_only ? n : 4 * n, 0.0);
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t k = 0; k < m.components.size(); ++k) {
      const mix::Gaussian& c = m.components[k];
      const double d = c.weight * c.density(grid.theta[i / np], grid.phi[i % np]) * area;
      const double z = std::clamp((grid.theta[i / np] - c.mu_t) / std::sqrt(c.s_tt), -1.5, 1.5);
      const double rgb[3] = {0.5 + 0.3 * z, 0.4, 0.5 - 0.3 * z};
      out[i] += d * (0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2]);
      if (!luminance_only)
        for (int q = 0; q < 3; ++q) out[(q + 1) * n + i] += d * rgb[q];
    }
  return out;
}

}  // namespace

TEST_CASE("four colour copies of equal amplitude have their component's mean and covariance", "[copies]") {
  mix::Gaussian g;
  g.mu_t = 0.4;
  g.mu_p = -1.1;
  g.s_tt = 0.02;
  g.s_tp = -0.011;
  g.s_pp = 0.09;
  const double rgb[3] = {1, 2, 3};
  double mt = 0, mp = 0, tt = 0, tp = 0, pp = 0;
  for (int m = 0; m < mix::kCopies; ++m) {
    const mix::Gaussian c = mix::copy_of(g, m, rgb);
    CHECK(c.rgb[1] == 2.0);
    mt += c.mu_t / 4;
    mp += c.mu_p / 4;
    tt += (c.s_tt + (c.mu_t - g.mu_t) * (c.mu_t - g.mu_t)) / 4;
    tp += (c.s_tp + (c.mu_t - g.mu_t) * (c.mu_p - g.mu_p)) / 4;
    pp += (c.s_pp + (c.mu_p - g.mu_p) * (c.mu_p - g.mu_p)) / 4;
  }
  CHECK(mt == Approx(g.mu_t).epsilon(1e-12));
  CHECK(mp == Approx(g.mu_p).epsilon(1e-12));
  CHECK(tt == Approx(g.s_tt).epsilon(1e-12));
  CHECK(tp == Approx(g.s_tp).epsilon(1e-12));
  CHECK(pp == Approx(g.s_pp).epsilon(1e-12));
  // colour_copies (the sweep's) is copy_of on the float32 parameters, copy by copy.
  Gmm one;
  add(one, 1, g.mu_t, g.mu_p, std::sqrt(g.s_tt), std::sqrt(g.s_pp), g.s_tp / std::sqrt(g.s_tt * g.s_pp));
  const Gmm copies = colour_copies(one);
  REQUIRE(copies.k() == 4);
  mix::Gaussian f = g;
  f.mu_t = float(one.mean[0]);
  f.mu_p = float(one.mean[1]);
  f.s_tt = float(one.cov[0]);
  f.s_tp = float(one.cov[1]);
  f.s_pp = float(one.cov[2]);
  for (int m = 0; m < 4; ++m) {
    const mix::Gaussian c = mix::copy_of(f, m, rgb);
    CHECK(copies.mean[std::size_t(2 * m)] == c.mu_t);
    CHECK(copies.mean[std::size_t(2 * m + 1)] == wrap_phi(c.mu_p));
    CHECK(copies.cov[std::size_t(3 * m)] == c.s_tt);
    CHECK(copies.cov[std::size_t(3 * m + 2)] == c.s_pp);
  }
}

TEST_CASE("the amplitudes of a known mixture of colour copies are recovered exactly", "[copies]") {
  ChannelSet set;
  set.grid = make_slice_grid(Domain::Hemisphere, 45, 90);
  set.channels = 3;
  const Gmm copies = colour_copies(lobes());
  const int K = copies.k();
  std::vector<double> truth(std::size_t(3 * K));
  for (std::size_t q = 0; q < truth.size(); ++q) truth[q] = 0.02 + 0.01 * double((q * 7) % 11);
  // The channels through the header: a slice with these copies.
  mix::SliceMixture m = make_slice_mixture(lobes().weight, lobes().mean, lobes().cov);
  std::vector<double> amp(std::size_t(12 * lobes().k()));
  for (int j = 0; j < K; ++j)
    for (int c = 0; c < 3; ++c) amp[std::size_t(3 * j + c)] = truth[std::size_t(c * K + j)];
  m.has_rgb = true;
  m.set_copies(amp);
  m.prepare();
  const std::size_t n = set.grid.cells(), np = set.grid.phi.size();
  const double area = axis_step(set.grid.theta) * axis_step(set.grid.phi);
  std::vector<double> v(3 * n);
  for (std::size_t i = 0; i < n; ++i) {
    double c[3];
    m.eval_rgb_param(set.grid.theta[i / np], set.grid.phi[i % np], c);
    for (int q = 0; q < 3; ++q) v[std::size_t(q) * n + i] = c[q] * area;
  }
  set.values = {v};
  const AmplitudeFit ref = fit_amplitudes(
      [&](const std::vector<AmplitudeQuery>& q) { return amplitude_sums_reference(set, q); }, set, {{0, copies}})[0];
  const EmEngine::AmpSlices prepared = EmEngine::amp_prepare(set);
  const AmplitudeFit dev = fit_amplitudes(
      [&](const std::vector<AmplitudeQuery>& q) { return device().amplitude_sums(prepared, q); }, set, {{0, copies}})[0];
  for (std::size_t q = 0; q < truth.size(); ++q) {
    INFO("channel " << q / std::size_t(K) << " copy " << q % std::size_t(K));
    CHECK(ref.amp[q] == Approx(truth[q]).epsilon(1e-4).margin(1e-5));  // the cells sum the energy by the midpoint rule
    CHECK(dev.amp[q] == Approx(ref.amp[q]).epsilon(1e-3));
  }
}

TEST_CASE("a colour that changes across its lobes gets copies: a lower RGB error, each channel's energy kept", "[copies]") {
  const SliceGrid grid = make_slice_grid(Domain::Hemisphere, 45, 90);
  const Gmm g = lobes();
  const std::vector<double> v = tilted(grid, g, false);
  const std::size_t n = grid.cells();
  const std::vector<double> y(v.begin(), v.begin() + long(n)), rgb(v.begin() + long(n), v.end());
  const StandInSlice slice{&g, &y, &rgb};
  const StandIn plain = fit_stand_ins(device(), grid, {slice}, -1.0)[0];
  const StandIn copied = fit_stand_ins(device(), grid, {slice}, kDefaultCopiesRatio)[0];
  CHECK(plain.copies.empty());
  REQUIRE(copied.copies.size() == std::size_t(12 * g.k()));
  CHECK(copied.scale == plain.scale);  // the luminance keeps its components
  // Both into a file, read back: the errors as the header evaluates them.
  const fs::path dir = fs::temp_directory_path() / "bsdfmix_colour_copies_test";
  fs::create_directories(dir);
  WeightedSlice ws;
  ws.theta = grid.theta;
  ws.phi = grid.phi;
  ws.w = y;
  double errors[2] = {0, 0};
  for (const bool with : {false, true}) {
    const StandIn& si = with ? copied : plain;
    MixtureFile m;
    m.domain = Domain::Hemisphere;
    m.table_theta_o = {0.3};
    m.table_phi_o = {0.0};
    m.add_slice(0.3, 0.0, si.scale, 0, 0, si.weight, g.mean, g.cov, &si.rgb, &si.copies);
    for (const char* storage : {"padded", "ragged", "padded_f32", "ragged_f32"}) {
      INFO((with ? "copies, " : "no copies, ") << storage);
      m.storage = parse_storage(storage, "test");
      const std::string path = (dir / (std::string(storage) + ".h5")).string();
      write_mixture_file(path, m);
      const MixtureFile back = read_mixture_file(path);
      CHECK(back.has_copies() == with);
      const mix::SliceMixture sm = slice_mixture(back, 0);
      CHECK(sm.colour.size() == (with ? std::size_t(4 * g.k()) : 0u));
      const StandInError e = stand_in_error(ws, rgb, sm);
      if (std::string(storage) == "padded") errors[with] = e.rgb_l1_rel;
      else CHECK(e.rgb_l1_rel == Approx(errors[with]).epsilon(1e-4));
      if (!with) continue;
      // Each channel's energy: the copies' in-domain masses times their amplitudes.
      for (int c = 0; c < 3; ++c) {
        double table = 0, stand_in = 0;
        for (std::size_t i = 0; i < n; ++i) table += rgb[std::size_t(c) * n + i];
        for (const auto& col : sm.colour) stand_in += col.rgb[c] * in_domain_mass(Domain::Hemisphere, col.mu_t, col.s_tt);
        CHECK(stand_in == Approx(table).epsilon(std::string(storage).find("f32") != std::string::npos ? 1e-6 : 1e-9));
      }
    }
  }
  INFO("RGB error without copies " << errors[0] << ", with " << errors[1]);
  CHECK(errors[1] < 0.5 * errors[0]);
  // rgb_scale stays each component's integral: the sum of its copies' amplitudes.
  for (int j = 0; j < g.k(); ++j)
    for (int c = 0; c < 3; ++c) {
      double sum = 0;
      for (int m = 0; m < 4; ++m) sum += copied.copies[std::size_t((4 * j + m) * 3 + c)];
      CHECK(copied.rgb[std::size_t(3 * j + c)] == Approx(sum).epsilon(1e-12));
    }
}

TEST_CASE("rgb_copies is checked on read", "[copies]") {
  const fs::path dir = fs::temp_directory_path() / "bsdfmix_colour_copies_test";
  fs::create_directories(dir);
  const Gmm g = lobes();
  MixtureFile m;
  m.domain = Domain::Hemisphere;
  m.table_theta_o = {0.3};
  m.table_phi_o = {0.0};
  const std::vector<double> rgb(6, 0.1), copies(24, 0.025);
  m.add_slice(0.3, 0.0, 1.0, 0, 0, g.weight, g.mean, g.cov, &rgb, &copies);
  m.rgb_copies[5] = -1;
  const std::string path = (dir / "negative.h5").string();
  write_mixture_file(path, m);
  CHECK_THROWS_WITH(read_mixture_file(path), Catch::Contains("slice 0 component 0: rgb_copies is not a finite non-negative"));
  // A file whose rgb_copies has the wrong shape, or whose copies_offset does not follow k,
  // is refused by name.
  auto replace = [&](const char* name, hid_t type, const std::vector<hsize_t>& dims, const void* data) {
    m.rgb_copies[5] = 0.01;
    write_mixture_file(path, m);
    const hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    REQUIRE(f >= 0);
    H5Ldelete(f, name, H5P_DEFAULT);
    const hid_t space = H5Screate_simple(int(dims.size()), dims.data(), nullptr);
    const hid_t d = H5Dcreate2(f, name, type, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    H5Dwrite(d, type == H5T_STD_I32LE ? H5T_NATIVE_INT32 : H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, data);
    H5Dclose(d);
    H5Sclose(space);
    H5Fclose(f);
  };
  const std::vector<double> zeros(24, 0.0);
  replace("/mixture/rgb_copies", H5T_IEEE_F64LE, {1, 2, 12}, zeros.data());
  CHECK_THROWS_WITH(read_mixture_file(path), Catch::Contains("rgb_copies: shape [1, 2, 12], expected [2, 4, 3]"));
  const std::int32_t five = 5;
  replace("/mixture/copies_offset", H5T_STD_I32LE, {1}, &five);
  CHECK_THROWS_WITH(read_mixture_file(path), Catch::Contains("copies_offset: slice 0 starts at 5, expected 0"));
  // Only the slices with copies take rows: a file of one slice with and one without.
  MixtureFile two = m;
  two.add_slice(0.6, 0.0, 1.0, 0, 0, g.weight, g.mean, g.cov, &rgb);
  write_mixture_file(path, two);
  const MixtureFile back = read_mixture_file(path);
  CHECK(back.rgb_copies == two.rgb_copies);
  CHECK(back.slice_copies(1).empty());
  CHECK(back.payload_bytes() == two.payload_bytes());
}

TEST_CASE("blending mixes slices with and without colour copies", "[copies]") {
  const Gmm g = lobes();
  mix::MixtureSet set;
  set.domain = Domain::Hemisphere;
  set.grid_theta_o = {0.2, 0.6};
  set.grid_phi_o = {0.0};
  for (int s = 0; s < 2; ++s) {
    mix::SliceMixture m = make_slice_mixture(g.weight, g.mean, g.cov);
    m.theta_o = set.grid_theta_o[std::size_t(s)];
    m.scale = 1;
    m.has_rgb = true;
    for (auto& c : m.components)
      for (int q = 0; q < 3; ++q) c.rgb[q] = 0.3 + 0.1 * q;
    if (s == 0) {
      std::vector<double> amp(24);
      for (std::size_t q = 0; q < amp.size(); ++q) amp[q] = 0.01 * double(1 + q % 5);
      m.set_copies(amp);
    }
    set.slices.push_back(m);
  }
  set.prepare();
  const mix::SliceMixture b = set.blended(0.3, 0.7);
  CHECK(b.colour.size() == 8u + 2u);  // slice 0's copies and slice 1's components
  for (const double t : {0.3, 0.9, 1.4})
    for (const double p : {-2.5, 0.1, 1.0}) {
      double rgb[3], a[3], c[3], blended[3];
      set.eval_rgb(0.3, 0.7, t, p, rgb);
      set.slices[0].eval_rgb_param(t, wrap_phi(p - 0.7), a);
      set.slices[1].eval_rgb_param(t, wrap_phi(p - 0.7), c);
      b.eval_rgb_param(t, p, blended);
      const double j = std::sin(t) * std::cos(t);
      for (int q = 0; q < 3; ++q) {
        CHECK(rgb[q] == Approx((0.75 * a[q] + 0.25 * c[q]) / j).epsilon(1e-12));
        CHECK(blended[q] / j == Approx(rgb[q]).epsilon(1e-12));
      }
    }
}
