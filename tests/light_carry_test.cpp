// The lighting carried into a hit's frame for mis_product (host/render/light_carry.hpp,
// world_lighting.hpp): the carried mixture keeps the world mixture's value per direction
// (at random fiber and surface frames), the product of a BSDF mixture with it, sampled and
// taken to world directions as the renderer does, follows the density the renderer
// evaluates (Pearson chi-square over equal-area world bins; a density 10 % off is caught),
// broad components are left out, the renderer's per-vertex product (render/fast_product.hpp)
// samples its own density and agrees with the header's, and the sky's fit over world
// directions finds its sun.
// labels: render sample
#include <catch2/catch.hpp>

#include "chi_square.hpp"
#include "gaussians.hpp"
#include "lighting_frames.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include "config/config.hpp"
#include "core/progress.hpp"
#include "render/fast_product.hpp"
#include "render/light_carry.hpp"
#include "render/world_lighting.hpp"
#include "scene/scene.hpp"

using namespace bsdfmix;
using namespace bsdfmix::render;
using test::world_value;

namespace {

constexpr std::uint64_t kSeed = 20261201ull;
constexpr auto& gauss = test::prepared_gaussian;
render::LocalAxes random_frame(std::uint32_t index, Domain d) { return test::random_frame(kSeed, index, d); }

// The carried mixture's value at the same direction, in the frame's (theta, phi).
double local_value(const mix::SliceMixture& m, const LocalAxes& f, const Vec3& w) {
  double th, ph;
  local_angles(f, w, th, ph);
  return m.pdf_param(th, ph);
}

// The angle between a direction and the nearest pole of the frame.
double pole_angle(const LocalAxes& f, const Vec3& w) {
  const double z = std::abs(std::clamp(dot(w, f.axis), -1.0, 1.0));
  return std::acos(z);
}

}  // namespace

TEST_CASE("the carried lighting keeps the world mixture's value per direction", "[render][sample]") {
  int frames = 0;
  double worst = 0;
  for (std::uint32_t k = 0; k < 40; ++k) {
    const Domain d = k % 2 ? Domain::Hemisphere : Domain::Fiber;
    const LocalAxes f = random_frame(k, d);
    double u[4];
    mix::uniforms(kSeed, 8, k, u);
    // two compact components at random places, one of them correlated
    const std::vector<mix::Gaussian> world = {gauss(0.7, -1.1 + 2.2 * u[0], -kPi + 2 * kPi * u[1], 0.06, 0.09, 0.4),
                                              gauss(0.3, -1.1 + 2.2 * u[2], -kPi + 2 * kPi * u[3], 0.04, 0.05, 0.0)};
    const Vec3 m0 = local_direction(kWorldAxes, world[0].mu_t, world[0].mu_p), m1 = local_direction(kWorldAxes, world[1].mu_t, world[1].mu_p);
    // the linearization holds away from the frame's pole
    if (pole_angle(f, m0) < 0.5 || pole_angle(f, m1) < 0.5) continue;
    const mix::SliceMixture carried = carry_lighting(world, f);
    REQUIRE(carried.components.size() == 2);
    ++frames;
    // the values at the two means and at one standard deviation around each, relative to
    // the value at the first mean: the carried mixture is normalized, the world one not
    const double ref_w = world_value(world, m0), ref_l = local_value(carried, f, m0);
    for (const auto& g : world)
      for (const auto& off : {std::pair<double, double>{0, 0}, {1, 0}, {-1, 0}, {0, 1}, {0, -1}}) {
        const Vec3 w = local_direction(kWorldAxes, g.mu_t + off.first * std::sqrt(g.s_tt), g.mu_p + off.second * std::sqrt(g.s_pp));
        const double a = world_value(world, w) / ref_w, b = local_value(carried, f, w) / ref_l;
        if (a < 0.05) continue;
        worst = std::max(worst, std::abs(b / a - 1));
      }
  }
  std::printf("light_carry_test: %d frames, worst relative value error %.4f\n", frames, worst);
  REQUIRE(frames >= 20);
  // the linearization's own error at one standard deviation, half a radian or more from
  // the pole: a few percent (a transposed Jacobian or a wrong weight is off by tens)
  CHECK(worst < 0.06);
}

TEST_CASE("a lobe over the guide's map is carried as the same lobe over the world's map", "[render][sample][guide]") {
  // An isotropic lobe of standard deviation s on the sphere at a random direction, written
  // over each map (phi's deviation s / cos(theta) there): carried into a random frame, both
  // are the same Gaussian, whichever map it came from.
  int frames = 0;
  for (std::uint32_t k = 0; k < 40; ++k) {
    const Domain d = k % 2 ? Domain::Hemisphere : Domain::Fiber;
    const LocalAxes f = random_frame(k, d);
    double u[4];
    mix::uniforms(kSeed, 9, k, u);
    const double z = 2 * u[0] - 1, a = 2 * kPi * u[1], r = std::sqrt(1 - z * z), s = 0.05;
    const Vec3 w{r * std::cos(a), r * std::sin(a), z};
    auto lobe = [&](const LocalAxes& map) {
      mix::Gaussian g;
      local_angles(map, w, g.mu_t, g.mu_p);
      g.weight = 1;
      g.s_tt = s * s;
      g.s_pp = s * s / (std::cos(g.mu_t) * std::cos(g.mu_t));
      return std::vector<mix::Gaussian>{g};
    };
    const std::vector<mix::Gaussian> in_world = lobe(kWorldAxes), in_guide = lobe(kGuideAxes);
    // away from every map's pole, where the lobe is one Gaussian in each
    if (std::abs(in_world[0].mu_t) > 1.2 || std::abs(in_guide[0].mu_t) > 1.2 || pole_angle(f, w) < 0.5) continue;
    const mix::SliceMixture from_world = carry_lighting(in_world, f), from_guide = carry_lighting(in_guide, f, kGuideAxes);
    REQUIRE(from_world.components.size() == 1);
    REQUIRE(from_guide.components.size() == 1);
    const mix::Gaussian &x = from_world.components[0], &y = from_guide.components[0];
    CHECK(y.mu_t == Approx(x.mu_t).margin(1e-12));
    CHECK(y.mu_p == Approx(x.mu_p).margin(1e-12));
    CHECK(y.s_tt == Approx(x.s_tt).epsilon(1e-9));
    CHECK(y.s_pp == Approx(x.s_pp).epsilon(1e-9));
    CHECK(y.s_tp == Approx(x.s_tp).margin(1e-9 * std::sqrt(x.s_tt * x.s_pp)));
    ++frames;
  }
  REQUIRE(frames >= 10);
}

TEST_CASE("broad components are left out of the carried lighting", "[render][sample]") {
  mix::SliceMixture world;
  world.components = {gauss(0.5, 0.6, 0.7, 0.05, 0.05, 0), gauss(0.5, 0.0, 0.0, 0.9, 1.5, 0)};
  world.prepare();
  const std::vector<mix::Gaussian> compact = compact_components(world);
  REQUIRE(compact.size() == 1);
  CHECK(compact[0].mu_t == Approx(0.6));
}

namespace {

// Pearson chi-square of `n` samples of a product drawn as the renderer does (taken to world
// directions), over 20 x 40 equal-area world bins, against its density, and against the
// density 10 % off along z (which must be rejected).
template <class Sampler, class Pdf>
void check_world_samples(const char* what, std::uint32_t k, const LocalAxes& f, std::size_t components,
                         const Sampler& sample, const Pdf& pdf_local) {
  const int nz = 20, np = 40;
  const std::size_t n = 200000;
  const Domain d = f.domain;
  auto pdf = [&](const Vec3& w) {
    double th, ph;
    local_angles(f, w, th, ph);
    return pdf_local(th, ph);
  };
  std::vector<double> obs(std::size_t(nz * np + 1), 0.0), expct(obs.size(), 0.0), skew(obs.size(), 0.0);
  for (std::size_t i = 0; i < n; ++i) {
    double v[4];
    mix::uniforms(kSeed, 10 + k, i, v);
    const mix::Sample s = sample(v);
    if (!s.valid) {
      obs.back() += 1;
      continue;
    }
    const Vec3 w = local_direction(f, s.theta, s.phi);
    const int a = std::clamp(int((w[2] + 1) / 2 * nz), 0, nz - 1);
    const int b = std::clamp(int((std::atan2(w[1], w[0]) + kPi) / (2 * kPi) * np), 0, np - 1);
    obs[std::size_t(a * np + b)] += 1;
  }
  // expected: the density over each equal-area bin (z uniform, phi uniform), 12 x 12 points;
  // `skew`: the same with the density 10 % off along z, which the test must reject
  double mass = 0, mass_skew = 0;
  const double bin = 4 * kPi / double(nz * np);
  for (int a = 0; a < nz; ++a)
    for (int b = 0; b < np; ++b) {
      double acc = 0, acc_skew = 0;
      for (int i = 0; i < 12; ++i)
        for (int j = 0; j < 12; ++j) {
          const double z = -1 + 2 * (a + (i + 0.5) / 12) / nz, ph = -kPi + 2 * kPi * (b + (j + 0.5) / 12) / np;
          const double r = std::sqrt(std::max(0.0, 1 - z * z));
          const double p = pdf({r * std::cos(ph), r * std::sin(ph), z});
          acc += p;
          acc_skew += p * (1 + 0.1 * z);
        }
      expct[std::size_t(a * np + b)] = acc / 144 * bin * double(n);
      skew[std::size_t(a * np + b)] = acc_skew / 144 * bin * double(n);
      mass += acc / 144 * bin;
      mass_skew += acc_skew / 144 * bin;
    }
  expct.back() = std::max(0.0, 1 - mass) * double(n);
  skew.back() = std::max(0.0, 1 - mass_skew) * double(n);
  const test::ChiSquare c = test::pearson(obs, expct), cs = test::pearson(obs, skew);
  std::printf("light_carry_test: %s, frame %u (%s, %zu components): chi2 %.1f, dof %d, p-value %.4f; 10%% off: p-value %.2g\n",
              what, k, d == Domain::Fiber ? "fiber" : "surface", components, c.stat, c.dof, c.p, cs.p);
  INFO(what << ", frame " << k << ": chi2 " << c.stat << " dof " << c.dof);
  CHECK(c.p > 0.001);
  CHECK(cs.p < 1e-6);
}

// The test BSDF mixture of frame k: a lobe at the specular cone or mirror and a broad one.
mix::SliceMixture test_bsdf(std::uint32_t k, Domain d) {
  double u[4];
  mix::uniforms(kSeed, 9, k, u);
  const double to = d == Domain::Fiber ? -1.2 + 2.4 * u[0] : 1.2 * u[0];
  mix::SliceMixture bsdf;
  bsdf.components = {gauss(0.6, d == Domain::Fiber ? -to : to, d == Domain::Fiber ? 0.0 : kPi - 0.01, 0.15, 0.8, 0.1),
                     gauss(0.4, d == Domain::Fiber ? 0.0 : 0.7, 0.5, 0.7, 2.0, 0.0)};
  bsdf.prepare();
  return bsdf;
}

const std::vector<mix::Gaussian> kTestWorld = {gauss(0.8, 0.9, 0.6, 0.05, 0.07, 0.2),
                                               gauss(0.2, -0.3, -2.0, 0.2, 0.3, -0.3)};

}  // namespace

TEST_CASE("the carried product, sampled as the renderer does, follows its density in world directions",
          "[render][sample]") {
  int checked = 0;
  for (std::uint32_t k = 0; k < 8; ++k) {
    const Domain d = k < 6 ? Domain::Fiber : Domain::Hemisphere;
    const LocalAxes f = random_frame(100 + k, d);
    const mix::SliceMixture bsdf = test_bsdf(k, d);
    const mix::SliceMixture carried = carry_lighting(kTestWorld, f);
    if (carried.components.empty()) continue;
    mix::SliceMixture prod;
    try {
      prod = mix::product(bsdf, 0.0, carried, mix::ProductOptions{0.99, 32});
    } catch (const std::invalid_argument&) {
      continue;
    }
    check_world_samples(
        "header product", k, f, prod.components.size(), [&](const double* v) { return prod.sample(d, v[0], v[1], v[2]); },
        [&](double th, double ph) { return prod.pdf_omega(d, th, ph); });
    ++checked;
  }
  CHECK(checked >= 6);
}

TEST_CASE("the renderer's per-vertex product (float, reused buffers) samples its own density, the header's product",
          "[render][sample]") {
  // FastProduct, as mis_product builds it at every vertex: a chi-square of its samples
  // against its pdf_omega, its density equal to that of its components as header
  // Gaussians (the float parameters are what is sampled), and close to the header's
  // product of the same two mixtures (the same pairs kept: the pruning bound drops only
  // what the header drops too).
  const CarrySource source(kTestWorld);
  FastProduct fp;  // one object for every frame: its buffers are reused
  int checked = 0;
  for (std::uint32_t k = 0; k < 8; ++k) {
    const Domain d = k < 6 ? Domain::Fiber : Domain::Hemisphere;
    const LocalAxes f = random_frame(100 + k, d);
    const mix::SliceMixture bsdf = test_bsdf(k, d);
    ProductFactor factor;
    factor.assign(bsdf);
    const mix::ProductOptions o{0.99, 32};
    if (!fp.build(factor, source, f, o)) continue;
    const mix::SliceMixture own = fp.mixture();
    const mix::SliceMixture header = mix::product(bsdf, 0.0, carry_lighting(kTestWorld, f), o);
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
    std::printf("light_carry_test: per-vertex product, frame %u: %zu components (header %zu); density against its own "
                "Gaussians within %.2g, against the header's product within %.2g\n",
                k, fp.size(), header.components.size(), worst_own, worst_header);
    CHECK(worst_own < 1e-4);
    // the header sums images out to 9 sigma, this product weighs pairs at the nearest three;
    // on a surface it also leaves out what is far below the horizon
    if (d == Domain::Fiber) CHECK(worst_header < 0.02);
    check_world_samples(
        "per-vertex product", k, f, fp.size(), [&](const double* v) { return fp.sample(d, v[0], v[1], v[2]); },
        [&](double th, double ph) { return fp.pdf_omega(d, th, ph); });
    ++checked;
    if (k % 3 == 0) {  // cut to two components: the selection, and still the density of what is sampled
      REQUIRE(fp.build(factor, source, f, mix::ProductOptions{0.99, 2}));
      CHECK(fp.size() <= 2);
      check_world_samples(
          "per-vertex product cut to 2", k, f, fp.size(), [&](const double* v) { return fp.sample(d, v[0], v[1], v[2]); },
          [&](double th, double ph) { return fp.pdf_omega(d, th, ph); });
    }
  }
  CHECK(checked >= 6);
}

TEST_CASE("the sky fitted over world directions holds its sun in a compact component", "[render]") {
  Progress::set_enabled(false);
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "bsdfmix_light_carry_test";
  std::filesystem::remove_all(dir);
  RenderSettings s;
  s.file = "light_carry_test";
  s.output = dir.string();
  s.estimators = {PathEstimator::MisProduct};
  s.lighting = parse_scene(YAML::Load("name: sun\nconstant: 0.05\nlobes:\n  - direction: [0.35, 0.25, 0.9]\n"
                                      "    radius_deg: 4\n    radiance: 40\n"),
                           "sun.yaml", "", Domain::Hemisphere);
  REQUIRE(needs_world_lighting(s));
  FitSection fit;
  fit.k_max = 6;
  const std::vector<mix::Gaussian> compact = world_lighting(s, fit, "");
  const Vec3 sun = s.lighting.lobes.at(0).direction;
  double best = 10, weight = 0;
  for (const auto& g : compact) {
    const double a = std::acos(std::clamp(dot(local_direction(kWorldAxes, g.mu_t, g.mu_p), sun), -1.0, 1.0));
    if (a < best) {
      best = a;
      weight = g.weight;
    }
  }
  std::printf("light_carry_test: the sun: %zu compact components, the nearest %.2f deg off, weight %.3f\n",
              compact.size(), best * 180 / kPi, weight);
  CHECK(best < 1.0 * kPi / 180);
  CHECK(weight > 0.1);
  std::filesystem::remove_all(dir);
}
