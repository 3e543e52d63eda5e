// kernels/sample.cl (sample_mixture, eval_mixture) against its CPU reference, the
// renderer-facing header include/bsdfmix/mixture.hpp (host/sampling/sample_reference.cpp):
// Philox against Random123, Pearson chi-square of samples against the pdf (a lobe across
// phi = +-pi, a lobe cut by the theta border, interpolated omega_o, both domains), the pdf
// integrating to 1 - P(invalid), kernel and header agreeing sample for sample, and the
// `bsdfmix sample` command.
#include <Random123/philox.h>
#include <catch2/catch.hpp>

#include "chi_square.hpp"
#include "gaussians.hpp"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "core/progress.hpp"
#include "device/device.hpp"
#include "io/mixture_file.hpp"
#include "sampling/sampling.hpp"

using namespace bsdfmix;

namespace {

using bsdfmix::test::gaussian;

// Fixed seed (printed); SAMPLE_TEST_SEED overrides it to re-check with other streams.
const std::uint64_t kSeed = std::getenv("SAMPLE_TEST_SEED") ? std::strtoull(std::getenv("SAMPLE_TEST_SEED"), nullptr, 10)
                                                             : 20240611ull;


// Fiber set on a 3-slice theta_o grid (azimuthal): slice 0 has a lobe across phi = +-pi
// and one cut by theta = pi/2; slice 1 a correlated lobe; slice 2 a broad one cut by -pi/2.
mix::MixtureSet fiber_set() {
  mix::MixtureSet set;
  set.domain = mix::Domain::Fiber;
  set.azimuthal = true;
  set.grid_theta_o = {-0.6, 0.0, 0.6};
  set.grid_phi_o = {0.0};
  mix::SliceMixture a, b, c;
  a.theta_o = -0.6;
  a.scale = 0.8;
  a.components = {gaussian(0.5, 0.2, 3.0, 0.15, 0.3, 0.2), gaussian(0.3, 1.45, -0.5, 0.12, 0.4, -0.3),
                  gaussian(0.2, -0.3, 0.8, 0.3, 0.8, 0.0)};
  b.theta_o = 0.0;
  b.scale = 1.1;
  b.components = {gaussian(0.7, 0.1, -2.9, 0.08, 0.2, 0.6), gaussian(0.3, 0.0, 1.0, 0.4, 1.2, -0.4)};
  c.theta_o = 0.6;
  c.scale = 0.5;
  c.components = {gaussian(1.0, -1.3, 0.0, 0.35, 2.5, 0.1)};
  set.slices = {a, b, c};
  set.prepare();
  return set;
}

// Hemisphere set, no azimuthal symmetry: 2 x 2 omega_o grid, lobes cut by theta = 0
// and pi/2.
mix::MixtureSet hemisphere_set() {
  mix::MixtureSet set;
  set.domain = mix::Domain::Hemisphere;
  set.azimuthal = false;
  set.grid_theta_o = {0.4, 1.0};
  set.grid_phi_o = {-kPi / 2, kPi / 2};
  const double tos[2] = {0.4, 1.0}, pos[2] = {-kPi / 2, kPi / 2};
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j) {
      mix::SliceMixture s;
      s.theta_o = tos[i];
      s.phi_o = pos[j];
      s.scale = 0.5 + 0.1 * (2 * i + j);
      s.components = {gaussian(0.6, 0.1 + 0.3 * i, pos[j] + kPi, 0.2, 0.5, 0.3),
                      gaussian(0.4, 1.4, pos[j] - 0.5 * i, 0.15, 0.6, -0.2)};
      set.slices.push_back(s);
    }
  set.prepare();
  return set;
}

// The same grids on the equal-area maps (docs/formats.md, "Maps"): on the cylinder a lobe at
// the fiber axis and one across phi = +-pi; on the disk a lobe at the pole, one cut by the
// horizon, and a Lambertian base on two of the four slices.
mix::MixtureSet cylinder_set() {
  mix::MixtureSet set = fiber_set();
  set.map = mix::Map::Cylinder;
  set.slices[0].components = {gaussian(0.5, 0.2, 3.0, 0.1, 0.3, 0.2), gaussian(0.3, 0.97, -0.5, 0.05, 0.4, -0.3),
                              gaussian(0.2, -0.3, 0.8, 0.25, 0.8, 0.0)};
  set.slices[2].components = {gaussian(1.0, -0.8, 0.0, 0.3, 2.5, 0.1)};
  set.prepare();
  return set;
}

mix::MixtureSet disk_set() {
  mix::MixtureSet set = hemisphere_set();
  set.map = mix::Map::Disk;
  for (std::size_t k = 0; k < set.slices.size(); ++k) {
    mix::SliceMixture& s = set.slices[k];
    s.components = {gaussian(0.6, 0.02, -0.01, 0.08, 0.1, 0.3), gaussian(0.4, 1.1, 0.6 - 0.4 * double(k), 0.2, 0.25, -0.2)};
    s.base = k % 2 ? 0.0 : 0.5;
  }
  set.prepare();
  return set;
}

const Device& device() {
  static std::vector<Device> d = select_devices("");
  return d.front();
}

// Integral of the set's pdf_param over [t0, t1] x [p0, p1] (Gauss-Legendre 6 x 6).
double bin_mass(const mix::MixtureSet& set, double to, double po, double t0, double t1, double p0, double p1) {
  static const double x[6] = {-0.9324695142, -0.6612093865, -0.2386191861, 0.2386191861, 0.6612093865, 0.9324695142};
  static const double w[6] = {0.1713244924, 0.3607615730, 0.4679139346, 0.4679139346, 0.3607615730, 0.1713244924};
  double s = 0;
  for (int i = 0; i < 6; ++i)
    for (int j = 0; j < 6; ++j) {
      const double t = 0.5 * (t0 + t1) + 0.5 * (t1 - t0) * x[i], p = 0.5 * (p0 + p1) + 0.5 * (p1 - p0) * x[j];
      s += w[i] * w[j] * set.pdf_param(to, po, t, p);
    }
  return s * 0.25 * (t1 - t0) * (p1 - p0);
}

struct Chi2 {
  double stat = 0, p = 0, mass = 0, invalid = 0;
  int dof = 0;
};

// Pearson chi-square of samples against the pdf on a theta x phi histogram plus one
// "invalid" bin; bins expecting fewer than 5 samples are pooled (as Mitsuba's chi2 test).
Chi2 chi2(const mix::MixtureSet& set, double to, double po, const std::vector<mix::Sample>& s) {
  const int nt = 40, np = 80;
  const double lo = set.domain == mix::Domain::Fiber ? -kPi / 2 : 0.0, hi = kPi / 2;
  std::vector<double> obs(std::size_t(nt * np + 1), 0.0), expct(obs.size(), 0.0);
  for (const auto& x : s) {
    if (!x.valid) {
      obs.back() += 1;
      continue;
    }
    const int i = std::min(nt - 1, int((x.theta - lo) / (hi - lo) * nt));
    const int j = std::min(np - 1, int((x.phi + kPi) / (2 * kPi) * np));
    obs[std::size_t(i * np + j)] += 1;
  }
  Chi2 r;
  const double N = double(s.size());
  for (int i = 0; i < nt; ++i)
    for (int j = 0; j < np; ++j) {
      const double m = bin_mass(set, to, po, lo + (hi - lo) * i / nt, lo + (hi - lo) * (i + 1) / nt,
                                -kPi + 2 * kPi * j / np, -kPi + 2 * kPi * (j + 1) / np);
      r.mass += m;
      expct[std::size_t(i * np + j)] = m * N;
    }
  expct.back() = std::max(0.0, 1 - r.mass) * N;
  r.invalid = obs.back() / N;
  const bsdfmix::test::ChiSquare c = bsdfmix::test::pearson(obs, expct);
  r.stat = c.stat;
  r.p = c.p;
  r.dof = c.dof;
  return r;
}

void check_chi2(const mix::MixtureSet& set, double to, double po, const char* what) {
  const std::size_t n = 400000;
  for (int dev = 0; dev < 2; ++dev) {
    const auto s = dev ? sample_device(device(), set, to, po, kSeed, kSampleStream, 0, n)
                       : sample_cpu(set, to, po, kSeed, kSampleStream, 0, n);
    const Chi2 c = chi2(set, to, po, s);
    INFO(what << (dev ? " (device)" : " (CPU header)") << ": seed " << kSeed << ", chi2 " << c.stat << " with "
              << c.dof << " dof, p-value " << c.p << "; pdf mass " << c.mass << ", invalid fraction " << c.invalid);
    std::printf("sample_test: %s %s: seed %llu, chi2 %.1f, dof %d, p-value %.4f, mass %.6f, 1 - invalid %.6f\n", what,
                dev ? "device" : "cpu", (unsigned long long)kSeed, c.stat, c.dof, c.p, c.mass, 1 - c.invalid);
    CHECK(c.p > 0.01);
    // The pdf integrates to 1 - P(invalid): quadrature against the empirical fraction.
    const double se = std::sqrt(std::max(c.invalid * (1 - c.invalid), 1e-12) / double(n));
    CHECK(std::abs(c.mass - (1 - c.invalid)) < 4 * se + 2e-4);
  }
}

}  // namespace

TEST_CASE("Philox4x32-10 of the header matches Random123", "[sample]") {
  r123::Philox4x32 rng;
  const std::uint32_t ctrs[4][4] = {{0, 0, 0, 0}, {1, 2, 3, 4}, {0xffffffffu, 0xffffffffu, 0xffffffffu, 0xffffffffu},
                                    {123456789u, 0, kSampleStream, 77}};
  const std::uint32_t keys[3][2] = {{0, 0}, {0xdeadbeefu, 0xcafef00du}, {1, 0}};
  for (const auto& c : ctrs)
    for (const auto& k : keys) {
      const auto ref = rng({{c[0], c[1], c[2], c[3]}}, {{k[0], k[1]}});
      const auto mine = mix::philox4x32_10(c, k);
      for (int i = 0; i < 4; ++i) CHECK(mine.v[i] == ref.v[i]);
    }
}

TEST_CASE("chi-square: fiber slice with a lobe across phi = +-pi and one cut by theta = pi/2", "[sample]") {
  Progress::set_enabled(false);
  check_chi2(fiber_set(), -0.6, 0.0, "fiber grid slice");
}

TEST_CASE("chi-square: fiber omega_o between grid slices, rotated by phi_o", "[sample]") {
  check_chi2(fiber_set(), -0.25, 1.3, "fiber interpolated");
  check_chi2(fiber_set(), 0.45, -2.0, "fiber interpolated, broad cut lobe");
}

TEST_CASE("chi-square: hemisphere, four-slice blend without symmetry", "[sample]") {
  check_chi2(hemisphere_set(), 0.7, 0.3, "hemisphere 4-way blend");
}

// The same sets, interpolated between slices by moving the components (displacement).
mix::MixtureSet displaced(mix::MixtureSet set) {
  set.interpolation = mix::Interpolation::Displace;
  set.prepare();
  return set;
}

TEST_CASE("chi-square: the equal-area maps, the disk with a Lambertian base", "[sample]") {
  check_chi2(cylinder_set(), -0.25, 1.3, "cylinder interpolated");
  check_chi2(cylinder_set(), -0.6, 0.0, "cylinder grid slice, lobe at the axis");
  check_chi2(disk_set(), 0.7, 0.3, "disk 4-way blend with a base");
  check_chi2(displaced(disk_set()), 0.55, -1.0, "disk displaced with a base");
  // the density per steradian has a finite limit at the poles (the map's point of it)
  const mix::MixtureSet c = cylinder_set(), d = disk_set();
  for (double phi : {-2.0, 0.3, 2.9}) {
    CHECK(c.pdf_omega(-0.6, 0.0, kPi / 2 - 1e-6, phi) == Approx(c.pdf_omega(-0.6, 0.0, kPi / 2 - 1e-5, phi)).epsilon(1e-3));
    CHECK(d.pdf_omega(0.7, 0.3, 1e-6, phi) == Approx(d.pdf_omega(0.7, 0.3, 1e-5, phi)).epsilon(1e-3));
    CHECK(d.pdf_omega(0.7, 0.3, 1e-6, phi) > 0.1);
  }
}

TEST_CASE("chi-square: displacement interpolation between slices, both domains", "[sample]") {
  check_chi2(displaced(fiber_set()), -0.25, 1.3, "fiber displaced");
  check_chi2(displaced(fiber_set()), 0.45, -2.0, "fiber displaced, broad cut lobe");
  check_chi2(displaced(hemisphere_set()), 0.7, 0.3, "hemisphere displaced, 4 slices");
  // random omega_o (fixed stream): the interpolated mixture is still what is sampled
  for (int i = 0; i < 3; ++i) {
    double u[4];
    mix::uniforms(kSeed, 0x76696577u, std::uint64_t(i), u);
    check_chi2(displaced(fiber_set()), -0.6 + 1.2 * u[0], -kPi + 2 * kPi * u[1], "fiber displaced, random omega_o");
  }
}

TEST_CASE("a lobe that moves between two slices is interpolated as one lobe at its place", "[sample]") {
  // A mirror-like lobe at theta_i = theta_o in two slices 0.2 rad apart, with a broad
  // second component; halfway, the lobe sits at 0.3 as one peak.
  mix::MixtureSet set;
  set.domain = mix::Domain::Hemisphere;
  set.azimuthal = true;
  set.grid_theta_o = {0.2, 0.4};
  set.grid_phi_o = {0.0};
  for (double to : set.grid_theta_o) {
    mix::SliceMixture s;
    s.theta_o = to;
    s.scale = 1;
    s.components = {gaussian(0.2, 0.7, 0.5, 0.3, 0.8, 0.0), gaussian(0.8, to, kPi - 0.01, 0.02, 0.04, 0.1)};
    set.slices.push_back(s);
  }
  const mix::MixtureSet blend = [&] { auto b = set; b.prepare(); return b; }();
  const mix::MixtureSet moved = displaced(set);
  // the pdf along theta at the lobe's phi, halfway between the slices
  auto peaks = [](const mix::MixtureSet& m) {
    std::vector<double> at;
    double prev = 0, cur = m.pdf_param(0.3, 0.0, 0.0, kPi - 0.01);
    for (int i = 1; i <= 600; ++i) {
      const double next = m.pdf_param(0.3, 0.0, 0.001 * (i + 1), kPi - 0.01);
      if (cur > prev && cur >= next && cur > 1.0) at.push_back(0.001 * i);
      prev = cur;
      cur = next;
    }
    return at;
  };
  const auto one = peaks(moved), two = peaks(blend);
  REQUIRE(one.size() == 1);
  CHECK(std::abs(one[0] - 0.3) < 0.002);
  CHECK(two.size() == 2);  // the blend splits it at the slices' places
  // the moved lobe keeps its width and mass: its peak is the slices' peak height
  CHECK(moved.pdf_param(0.3, 0.0, 0.3, kPi - 0.01) ==
        Approx(blend.pdf_param(0.2, 0.0, 0.2, kPi - 0.01)).epsilon(1e-3));
  // at the slices themselves both interpolations are the slice
  for (double t : {0.05, 0.2, 0.35, 0.6})
    CHECK(moved.pdf_param(0.2, 0.0, t, 3.0) == Approx(blend.pdf_param(0.2, 0.0, t, 3.0)).epsilon(1e-12));
  // the plan moves the narrow lobe alone; the broad component (sigma 0.8) is blended
  const auto plan = mix::transport_plan(moved.slices[0], moved.slices[1]).flows;
  REQUIRE(plan.size() == 1);
  CHECK(plan[0].i == 1);
  CHECK(plan[0].j == 1);
}

TEST_CASE("the pdf's mass is the normal mass inside the theta range (analytic)", "[sample]") {
  const auto set = fiber_set();
  // grid slice 2: one component, theta marginal N(-1.3, 0.35^2) cut at -pi/2
  const double analytic = 0.5 * (std::erf((kPi / 2 + 1.3) / (0.35 * std::sqrt(2.0))) -
                                 std::erf((-kPi / 2 + 1.3) / (0.35 * std::sqrt(2.0))));
  double q = 0;
  for (int i = 0; i < 60; ++i)
    for (int j = 0; j < 60; ++j)
      q += bin_mass(set, 0.6, 0.0, -kPi / 2 + kPi * i / 60, -kPi / 2 + kPi * (i + 1) / 60, -kPi + 2 * kPi * j / 60,
                    -kPi + 2 * kPi * (j + 1) / 60);
  CHECK(std::abs(q - analytic) < 1e-6);
}

TEST_CASE("kernel and header agree sample for sample", "[sample]") {
  for (int which = 0; which < 4; ++which) {
    const auto set = which == 3 ? disk_set() : which == 2 ? cylinder_set() : which ? hemisphere_set() : fiber_set();
    const double to = which % 2 ? 0.55 : -0.3, po = which % 2 ? 2.0 : 0.7;
    const std::size_t n = 200000;
    const std::uint64_t first = 5000000000ull;  // above 2^32: the high counter word
    const auto a = sample_cpu(set, to, po, kSeed, kSampleStream, first, n);
    const auto b = sample_device(device(), set, to, po, kSeed, kSampleStream, first, n);
    REQUIRE(a.size() == b.size());
    std::size_t mismatched = 0, valid = 0;
    double worst_angle = 0, worst_pdf = 0;
    for (std::size_t i = 0; i < n; ++i) {
      const double da = std::max(std::abs(a[i].theta - b[i].theta), std::abs(wrap_phi(a[i].phi - b[i].phi)));
      // the kernel's pdf against the header's at the kernel's point (near theta = 0 the
      // hemisphere's 1 / sin(theta) magnifies float rounding of the point itself)
      const double dp = a[i].valid ? std::abs(b[i].pdf_omega / set.pdf_omega(to, po, b[i].theta, b[i].phi) - 1) : 0.0;
      if (!a[i].valid && !b[i].valid) continue;  // both invalid: no point to compare
      if (a[i].valid != b[i].valid || da > 1e-3) {
        ++mismatched;  // a component or validity boundary hit within float rounding
        continue;
      }
      valid += a[i].valid;
      worst_angle = std::max(worst_angle, da);
      if (a[i].pdf_omega > 1e-3 && dp > worst_pdf) {
        worst_pdf = dp;
        if (std::getenv("SAMPLE_DEBUG"))
          std::printf("  i %zu theta %.9g/%.9g phi %.9g/%.9g pdf %.9g/%.9g\n", i, a[i].theta, b[i].theta, a[i].phi,
                      b[i].phi, a[i].pdf_omega, b[i].pdf_omega);
      }
    }
    const char* names[4] = {"fiber", "hemisphere", "cylinder", "disk with a base"};
    std::printf("sample_test: device vs header (%s): %zu of %zu differ, worst angle %.2e rad, worst pdf %.2e rel\n",
                names[which], mismatched, n, worst_angle, worst_pdf);
    CHECK(mismatched <= n / 10000);
    CHECK(valid > n / 2);
    // docs/sampling.md: about 1e-6 rad and 4e-6 in pdf (2x margin for another device's float
    // rounding); on the maps asin and atan2 near the axis and the pole magnify the point's
    // float rounding a few times
    CHECK(worst_angle < (which >= 2 ? 1e-5 : 2e-6));
    CHECK(worst_pdf < 8e-6);
    // the same stream at another offset: batch independence
    const auto c = sample_device(device(), set, to, po, kSeed, kSampleStream, first + 1000, 10);
    for (std::size_t i = 0; i < 10; ++i) CHECK(c[i].theta == b[1000 + i].theta);
  }
}

TEST_CASE("eval kernel: pdf_omega and the stand-in f match the header", "[sample]") {
  for (int which = 0; which < 4; ++which) {
    const auto set = which == 3 ? disk_set() : which == 2 ? cylinder_set() : which ? hemisphere_set() : fiber_set();
    const double to = which % 2 ? 0.8 : 0.2, po = which % 2 ? -1.0 : 0.4;
    std::vector<std::pair<double, double>> dirs;
    for (int i = 0; i < 30; ++i)
      for (int j = 0; j < 30; ++j)
        dirs.emplace_back((which % 2 ? 0.0 : -kPi / 2) + (which % 2 ? 1.0 : 2.0) * kPi / 2 * (i + 0.5) / 30,
                          -kPi + 2 * kPi * (j + 0.37) / 30);
    const auto r = eval_device(device(), set, to, po, dirs);
    double worst = 0;
    for (std::size_t k = 0; k < dirs.size(); ++k) {
      const double p = set.pdf_omega(to, po, dirs[k].first, dirs[k].second);
      const double f = set.eval_f(to, po, dirs[k].first, dirs[k].second);
      if (p > 1e-4) worst = std::max(worst, std::abs(r[k].first / p - 1));
      if (f > 1e-4) worst = std::max(worst, std::abs(r[k].second / f - 1));
      // the stand-in is scale * pdf (per slice, blended)
    }
    CHECK(worst < 1e-3);
  }
  // a grid slice: f = scale * pdf_omega exactly (fiber)
  const auto set = fiber_set();
  for (double t : {-1.0, 0.0, 0.9})
    CHECK(set.eval_f(0.0, 0.0, t, 0.5) == Approx(1.1 * set.pdf_omega(0.0, 0.0, t, 0.5)).epsilon(1e-12));
}

TEST_CASE("eval kernel: f is 0 at and past the hemisphere's horizon, as the header's", "[sample]") {
  for (const auto& set : {hemisphere_set(), disk_set()}) {
    const std::vector<std::pair<double, double>> dirs = {{kPi / 2, 0.4}, {kPi / 2, -2.0}, {1.6, 0.4}, {kPi / 2 - 1e-3, 0.4}};
    const auto r = eval_device(device(), set, 0.8, -1.0, dirs);
    for (std::size_t k = 0; k < 3; ++k) {
      CHECK(r[k].second == 0.0f);
      CHECK(set.eval_f(0.8, -1.0, dirs[k].first, dirs[k].second) == 0.0);
      CHECK(std::isfinite(r[k].first));
    }
    CHECK(r[3].second > 0.0f);  // just inside: finite and positive, as the header's
    CHECK(r[3].second == Approx(set.eval_f(0.8, -1.0, dirs[3].first, dirs[3].second)).epsilon(1e-3));
  }
}

TEST_CASE("eval kernel: phi images about the conditional mean (strong correlation, broad and sharp lobes)", "[sample]") {
  // The kernel takes each component's phi image nearest its conditional mean and then only
  // the images that can matter in float (host: make_query); the header sums every image
  // within 9 sigma_phi. Lobes with |rho| = 0.95, sigma_phi from 0.05 to 4 rad, means
  // outside [-pi, pi): the two must agree to float rounding everywhere the pdf is not
  // negligible, far tails included.
  mix::MixtureSet set;
  set.domain = mix::Domain::Fiber;
  set.azimuthal = true;
  set.grid_theta_o = {0.0};
  set.grid_phi_o = {0.0};
  mix::SliceMixture s;
  s.scale = 0.7;
  s.components = {gaussian(0.3, 0.2, 2.9, 0.3, 1.4, 0.95),   gaussian(0.2, -0.5, -3.5, 0.2, 2.2, -0.95),
                  gaussian(0.2, 0.9, 0.3, 0.1, 0.05, 0.5),   gaussian(0.1, 0.0, 4.0, 0.5, 4.0, 0.3),
                  gaussian(0.1, -1.2, -1.0, 0.25, 0.9, -0.7), gaussian(0.1, 1.3, 3.1, 0.15, 0.6, 0.9)};
  set.slices = {s};
  set.prepare();
  std::vector<std::pair<double, double>> dirs;
  for (int i = 0; i < 60; ++i)
    for (int j = 0; j < 120; ++j) dirs.emplace_back(-kPi / 2 + kPi * (i + 0.5) / 60, -kPi + 2 * kPi * (j + 0.29) / 120);
  const auto r = eval_device(device(), set, 0.0, 0.0, dirs);
  double worst = 0, peak = 0;
  for (const auto& d : dirs) peak = std::max(peak, set.pdf_omega(0.0, 0.0, d.first, d.second));
  for (std::size_t k = 0; k < dirs.size(); ++k) {
    const double p = set.pdf_omega(0.0, 0.0, dirs[k].first, dirs[k].second);
    if (p > 1e-6 * peak && std::abs(dirs[k].first) < 1.5) worst = std::max(worst, std::abs(r[k].first / p - 1));
  }
  std::printf("sample_test: eval kernel vs header, correlated broad and sharp lobes: worst pdf %.2e rel\n", worst);
  CHECK(worst < 2e-5);
}

TEST_CASE("bsdfmix sample writes theta,phi,pdf_omega,valid", "[sample][cli]") {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / "bsdfmix_sample_test";
  fs::create_directories(dir);
  const auto set = fiber_set();
  MixtureFile m;
  m.domain = Domain::Fiber;
  m.azimuthal = true;
  m.table_theta_o = set.grid_theta_o;
  m.table_phi_o = {0.0};
  for (const auto& s : set.slices) {
    std::vector<double> w, mean, cov;
    for (const auto& g : s.components) {
      w.push_back(g.weight);
      mean.insert(mean.end(), {g.mu_t, g.mu_p});
      cov.insert(cov.end(), {g.s_tt, g.s_tp, g.s_pp});
    }
    m.add_slice(s.theta_o, 0.0, s.scale, 0.0, 0.01, w, mean, cov);
  }
  const std::string file = (dir / "m.h5").string(), out = (dir / "s.csv").string(), out_cpu = (dir / "c.csv").string();
  write_mixture_file(file, m);
  const std::string base = std::string(BSDFMIX_BINARY) + " sample " + file + " --theta-o -0.25 --phi-o 1.3 -n 500 --seed 7 -q -o ";
  REQUIRE(std::system((base + out).c_str()) == 0);
  REQUIRE(std::system((base + out_cpu + " --cpu").c_str()) == 0);
  std::ifstream a(out), b(out_cpu);
  std::string la, lb;
  std::getline(a, la);
  CHECK(la == "theta,phi,pdf_omega,valid");
  std::getline(b, lb);
  int rows = 0;
  while (std::getline(a, la) && std::getline(b, lb)) {
    ++rows;
    double ta, pa, qa, tb, pb, qb;
    int va, vb;
    REQUIRE(std::sscanf(la.c_str(), "%lf,%lf,%lf,%d", &ta, &pa, &qa, &va) == 4);
    REQUIRE(std::sscanf(lb.c_str(), "%lf,%lf,%lf,%d", &tb, &pb, &qb, &vb) == 4);
    // the device's draws and the header's, as "kernel and header agree" above
    CHECK(std::abs(ta - tb) < 2e-6);
    CHECK(std::abs(wrap_phi(pa - pb)) < 2e-6);
    CHECK(va == vb);
    CHECK((va == 1 ? qa > 0 : qa == 0));
    if (va == 1 && vb == 1) {  // each pdf the header's at its own point (9 printed digits)
      CHECK(std::abs(qa / set.pdf_omega(-0.25, 1.3, ta, pa) - 1) < 8e-6);
      CHECK(std::abs(qb / set.pdf_omega(-0.25, 1.3, tb, pb) - 1) < 4e-6);
    }
  }
  CHECK(rows == 500);
  // errors are one line and non-zero
  CHECK(std::system((std::string(BSDFMIX_BINARY) + " sample " + file + " --theta-o 3 -n 5 -q -o " + out + " 2>/dev/null").c_str()) != 0);
}
