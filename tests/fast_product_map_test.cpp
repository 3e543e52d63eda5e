// The renderer's per-vertex product (host/render/fast_product.hpp) with a stand-in on an
// equal-area map: Lambert's disk for a surface (hemisphere, with a Lambertian base), the
// cylinder for a fiber. At random frames: the lighting carried into the map's plane keeps
// the world mixture's value per direction; the product's samples follow its pdf_omega
// (Pearson chi-square over equal-area bins of the frame; a density 10 % off is rejected);
// its density equals that of its own components and the header's product of the stand-in
// with the lighting carried into the plane; and it stays near the exact product of the
// stand-in and the world lighting (total variation within the linearization's error).
// labels: render sample
#include <catch2/catch.hpp>

#include "chi_square.hpp"
#include "gaussians.hpp"
#include "lighting_frames.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "render/fast_product.hpp"
#include "render/light_carry.hpp"

using namespace bsdfmix;
using namespace bsdfmix::render;

namespace {

constexpr std::uint64_t kSeed = 20261206ull;
constexpr auto& gauss = test::prepared_gaussian;
render::LocalAxes random_frame(std::uint32_t index, Domain d) { return test::random_frame(kSeed, index, d); }

// The world lighting over the world's (theta, phi): two compact lobes, one correlated.
const std::vector<mix::Gaussian> kWorld = {gauss(0.6, 0.5, 0.6, 0.08, 0.1, 0.3), gauss(0.4, -0.3, -2.0, 0.1, 0.12, -0.3)};
double world_value(const Vec3& w) { return test::world_value(kWorld, w); }

// The stand-in of frame k over its domain's equal-area map: a lobe at the specular cone
// (fiber) or mirror direction (surface) and a broad one; on the disk a Lambertian base too.
mix::SliceMixture stand_in(std::uint32_t k, Domain d) {
  double u[4];
  mix::uniforms(kSeed, 9, k, u);
  mix::SliceMixture s;
  s.map = mix::equal_area_map(d);
  if (d == Domain::Fiber) {
    const double to = -1.1 + 2.2 * u[0];
    s.components = {gauss(0.6, -std::sin(to), 0.0, 0.12, 0.8, 0.1), gauss(0.4, 0.0, 0.5, 0.5, 2.0, 0.0)};
  } else {
    const double r = 2 * std::sin(0.5 * 1.2 * u[0]);  // the mirror direction at phi = pi
    s.components = {gauss(0.6, -r, 0.0, 0.15, 0.2, 0.1), gauss(0.4, 0.2, 0.1, 0.6, 0.6, 0.0)};
    s.base = 0.3;  // a Lambertian base beside them, as the disk's fits have
  }
  s.prepare();
  return s;
}

// The frame's equal-area coordinate u (cos theta on a surface, sin theta on a fiber) and
// its direction at (u, phi).
double u_lo(Domain d) { return d == Domain::Fiber ? -1.0 : 0.0; }
Vec3 direction_at(const LocalAxes& f, double u, double phi) {
  const double theta = f.domain == Domain::Fiber ? std::asin(u) : std::acos(u);
  return local_direction(f, theta, phi);
}

// Pearson chi-square of the product's samples over nu x 32 equal-area bins of the frame
// against its pdf_omega, and against the density 10 % off along u (which must be rejected).
void check_samples(const FastProduct& fp, const LocalAxes& f, std::uint32_t k) {
  const Domain d = f.domain;
  const int nu = 16, np = 32;
  const std::size_t n = 100000;
  const double lo = u_lo(d), du = (1 - lo) / nu, dp = 2 * kPi / np;
  std::vector<double> obs(std::size_t(nu * np + 1), 0.0), expct(obs.size(), 0.0), skew(obs.size(), 0.0);
  double worst = 0;  // a sample's pdf_omega against pdf_omega at its direction
  for (std::size_t i = 0; i < n; ++i) {
    double v[4];
    mix::uniforms(kSeed, 10 + k, i, v);
    const mix::Sample s = fp.sample(d, v[0], v[1], v[2]);
    if (!s.valid) {
      obs.back() += 1;
      continue;
    }
    worst = std::max(worst, std::abs(s.pdf_omega / fp.pdf_omega(d, s.theta, s.phi) - 1));
    const double u = d == Domain::Fiber ? std::sin(s.theta) : std::cos(s.theta);
    const int a = std::clamp(int((u - lo) / du), 0, nu - 1), b = std::clamp(int((s.phi + kPi) / dp), 0, np - 1);
    obs[std::size_t(a * np + b)] += 1;
  }
  double mass = 0;
  std::vector<double> row(std::size_t(nu), 0.0);
  for (int a = 0; a < nu; ++a)
    for (int b = 0; b < np; ++b) {
      double acc = 0;
      for (int i = 0; i < 8; ++i)
        for (int j = 0; j < 8; ++j) {
          const double u = lo + (a + (i + 0.5) / 8) * du, ph = -kPi + (b + (j + 0.5) / 8) * dp;
          const double th = d == Domain::Fiber ? std::asin(u) : std::acos(u);
          acc += fp.pdf_omega(d, th, ph) * du * dp / 64;
        }
      expct[std::size_t(a * np + b)] = acc * double(n);
      row[std::size_t(a)] += acc;
      mass += acc;
    }
  expct.back() = std::max(0.0, 1 - mass) * double(n);
  // the density 10 % high below its median in u and 10 % low above it
  int median = 0;
  for (double below = row[0]; below < 0.5 * mass && median + 1 < nu; below += row[std::size_t(++median)]) {
  }
  for (std::size_t c = 0; c + 1 < obs.size(); ++c) skew[c] = expct[c] * (int(c) / np <= median ? 1.1 : 0.9);
  skew.back() = expct.back();
  const test::ChiSquare c = test::pearson(obs, expct), cs = test::pearson(obs, skew);
  std::printf("fast_product_map_test: frame %u (%s): mass %.4f, chi2 %.1f, dof %d, p-value %.4f; 10%% off: p-value "
              "%.2g; samples' pdf within %.2g\n",
              k, d == Domain::Fiber ? "cylinder" : "disk", mass, c.stat, c.dof, c.p, cs.p, worst);
  CHECK(worst < 1e-4);
  CHECK(c.p > 0.001);
  if (mass > 0.5) CHECK(cs.p < 1e-6);  // with enough samples in the domain to tell
}

// The total variation distance between the product's density and the exact product of the
// stand-in and the world lighting, both normalized over the domain, by a 200 x 400
// midpoint rule over equal-area cells of the frame; `mass` receives the product's mass in
// the domain.
double distance_to_exact(const FastProduct& fp, const mix::SliceMixture& s, const LocalAxes& f, double& mass) {
  const Domain d = f.domain;
  const int nu = 200, np = 400;
  const double lo = u_lo(d), cell = (1 - lo) / nu * 2 * kPi / np;
  std::vector<double> p, q;
  double z = 0;
  mass = 0;
  for (int a = 0; a < nu; ++a)
    for (int b = 0; b < np; ++b) {
      const double u = lo + (a + 0.5) * (1 - lo) / nu, ph = -kPi + (b + 0.5) * 2 * kPi / np;
      const double th = d == Domain::Fiber ? std::asin(u) : std::acos(u);
      p.push_back(fp.pdf_omega(d, th, ph));
      q.push_back(s.pdf_omega(d, th, ph) * world_value(direction_at(f, u, ph)));
      z += q.back() * cell;
      mass += p.back() * cell;
    }
  double tv = 0;
  for (std::size_t i = 0; i < p.size(); ++i) tv += 0.5 * std::abs(p[i] / mass - q[i] / z) * cell;
  return tv;
}

// The angle between a direction and the nearest pole of the frame.
double pole_angle(const LocalAxes& f, const Vec3& w) { return std::acos(std::abs(std::clamp(dot(w, f.axis), -1.0, 1.0))); }

}  // namespace

TEST_CASE("the lighting carried into a map's plane keeps the world mixture's value per direction", "[render][sample]") {
  int frames = 0;
  double worst = 0;
  for (std::uint32_t k = 0; k < 40; ++k) {
    const Domain d = k % 2 ? Domain::Hemisphere : Domain::Fiber;
    const mix::Map m = mix::equal_area_map(d);
    const LocalAxes f = random_frame(k, d);
    const Vec3 m0 = local_direction(kWorldAxes, kWorld[0].mu_t, kWorld[0].mu_p);
    const Vec3 m1 = local_direction(kWorldAxes, kWorld[1].mu_t, kWorld[1].mu_p);
    if (pole_angle(f, m0) < 0.5 || pole_angle(f, m1) < 0.5) continue;  // the cylinder's phi stretches there
    const mix::SliceMixture carried = carry_lighting(kWorld, f, kWorldAxes, m);
    REQUIRE(carried.map == m);
    REQUIRE(carried.components.size() == 2);
    ++frames;
    // the plane's density per unit (x, y) at a direction, relative to that at the first mean
    auto value = [&](const Vec3& w) {
      double th, ph, x, y;
      local_angles(f, w, th, ph);
      mix::to_map(m, th, ph, x, y);
      return carried.pdf_map(x, y);
    };
    const double ref_w = world_value(m0), ref_l = value(m0);
    for (const auto& g : kWorld)
      for (const auto& off : {std::pair<double, double>{0, 0}, {1, 0}, {-1, 0}, {0, 1}, {0, -1}}) {
        const Vec3 w = local_direction(kWorldAxes, g.mu_t + off.first * std::sqrt(g.s_tt), g.mu_p + off.second * std::sqrt(g.s_pp));
        const double a = world_value(w) / ref_w, b = value(w) / ref_l;
        if (a < 0.05 || (d == Domain::Hemisphere && dot(w, f.axis) < 0)) continue;  // below the surface
        worst = std::max(worst, std::abs(b / a - 1));
      }
  }
  std::printf("fast_product_map_test: %d frames, worst relative value error in the plane %.4f\n", frames, worst);
  REQUIRE(frames >= 20);
  // the linearization's error at one standard deviation (lobes of 0.08 to 0.12 radians)
  CHECK(worst < 0.12);
}

TEST_CASE("the per-vertex product on a map's plane samples its own density, the header's product's", "[render][sample]") {
  const CarrySource source(kWorld);
  FastProduct fp;
  int checked[2] = {0, 0};
  double worst_tv = 0;
  for (std::uint32_t k = 0; k < 12; ++k) {
    const Domain d = k % 2 ? Domain::Hemisphere : Domain::Fiber;
    const LocalAxes f = random_frame(200 + k, d);
    const mix::SliceMixture bsdf = stand_in(k, d);
    ProductFactor factor;
    factor.assign(bsdf);
    REQUIRE(factor.map == bsdf.map);
    const mix::ProductOptions o{0.999, 64};
    if (!fp.build(factor, source, f, o)) continue;
    const mix::SliceMixture own = fp.mixture();
    REQUIRE(own.map == bsdf.map);
    mix::SliceMixture header;
    try {
      header = mix::product(bsdf, 0.0, carry_lighting(kWorld, f, kWorldAxes, bsdf.map), o);
    } catch (const std::invalid_argument&) {
      continue;
    }
    double worst_own = 0, worst_header = 0;
    for (std::uint32_t i = 0; i < 2000; ++i) {
      double v[4];
      mix::uniforms(kSeed, 50 + k, i, v);
      const double th = d == Domain::Fiber ? -1.5 + 3.0 * v[0] : 1.5 * v[0], ph = -kPi + 2 * kPi * v[1];
      const double p = fp.pdf_omega(d, th, ph), po = own.pdf_omega(d, th, ph), ph_ = header.pdf_omega(d, th, ph);
      const double scale = 1e-3 * std::max(1.0, po);  // relative, and absolute where the density is small
      worst_own = std::max(worst_own, std::abs(p - po) / std::max(po, scale));
      worst_header = std::max(worst_header, std::abs(p - ph_) / std::max(ph_, scale));
    }
    double mass = 0;
    const double tv = distance_to_exact(fp, bsdf, f, mass);
    std::printf("fast_product_map_test: frame %u (%s): %zu components (header %zu); density against its own within "
                "%.2g, against the header's product within %.2g; total variation to the exact product %.4f\n",
                k, d == Domain::Fiber ? "cylinder" : "disk", fp.size(), header.components.size(), worst_own,
                worst_header, tv);
    CHECK(worst_own < 1e-4);
    // on a surface this product leaves out lighting 4 sigma below the horizon, the header not
    CHECK(worst_header < (d == Domain::Fiber ? 0.02 : 0.1));
    if (mass > 0.8) {  // not where most of the lighting is below the surface (its tails alone above)
      worst_tv = std::max(worst_tv, tv);
      CHECK(tv < 0.1);  // the lighting's linearization (and the pruning, 1e-3 of the mass)
    }
    check_samples(fp, f, k);
    ++checked[d == Domain::Fiber ? 0 : 1];
  }
  std::printf("fast_product_map_test: %d cylinder and %d disk frames, worst total variation %.4f\n", checked[0],
              checked[1], worst_tv);
  CHECK(checked[0] >= 3);
  CHECK(checked[1] >= 3);
}
