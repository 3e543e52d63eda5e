// The radiance field a path guide learns (host/guide/): a leaf's grid holds the estimate
// of the incident luminance per cell's solid angle; the fitted mixture recovers a known
// radiance field (one small emitter over a dim background) from samples drawn as a path
// tracer draws them; the kd-tree keeps regions with different light apart.
// labels: render
#include <catch2/catch.hpp>

#include <cmath>

#include "core/domain.hpp"
#include "core/hash.hpp"
#include "core/progress.hpp"
#include "device/device.hpp"
#include "guide/radiance_field.hpp"

using namespace bsdfmix;
using namespace bsdfmix::guide;

namespace {

// Uniforms in [0, 1) from splitmix64 over a counter.
struct Uniforms {
  std::uint64_t state;
  double uniform() { return double(splitmix64(state++) >> 11) * 0x1.0p-53; }
};


// Training samples at `n` vertices in the box [lo, lo + 1]^3: directions uniform over the
// sphere (density 1 / 4 pi, the vertex's own sampler's too, f = 1), L = `emitter` within
// `radius` of `toward` and 1 elsewhere.
void add_samples(std::vector<Sample>& out, std::size_t n, const Vec3& lo, const Vec3& toward, double radius,
                 double emitter, std::uint64_t seed) {
  Uniforms rng{seed << 32};
  const double cos_r = std::cos(radius);
  for (std::size_t i = 0; i < n; ++i) {
    Sample s;
    for (int a = 0; a < 3; ++a) s.position[a] = float(lo[std::size_t(a)] + rng.uniform());
    const double z = 2 * rng.uniform() - 1, a = 2 * kPi * rng.uniform(), r = std::sqrt(1 - z * z);
    const Vec3 w{r * std::cos(a), r * std::sin(a), z};
    const double L = dot(w, toward) >= cos_r ? emitter : 1.0;
    double theta, phi;
    guide_angles(w, theta, phi);
    s.theta = float(theta);
    s.phi = float(phi);
    s.radiance = float(L);
    s.pdf = float(1 / (4 * kPi));
    s.f = 1;
    s.pdf_bsdf = float(1 / (4 * kPi));
    out.push_back(s);
  }
}

FieldSettings settings() {
  FieldSettings s;
  s.fit.k_max = 6;
  s.fit.restarts = s.fit.final_restarts = 1;
  s.fit.iterations = 40;
  s.fit.final_iterations = 100;
  s.fit.refine = "none";
  return s;
}

// The mixture's probability of directions within `radius` of `toward` (a midpoint rule).
double mass_near(const mix::SliceMixture& m, const Vec3& toward, double radius) {
  double mass = 0;
  const int n = 400;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < 2 * n; ++j) {
      const double th = -kPi / 2 + (i + 0.5) * kPi / n, ph = -kPi + (j + 0.5) * kPi / n;
      if (dot(guide_direction(th, ph), toward) >= std::cos(radius)) mass += m.pdf_param(th, ph) * (kPi / n) * (kPi / n);
    }
  return mass;
}

}  // namespace

TEST_CASE("the guide's map and its inverse agree; the zenith is on its equator", "[guide]") {
  double th, ph;
  guide_angles({0, 0, 1}, th, ph);
  CHECK(std::abs(th) < 1e-12);
  CHECK(std::abs(ph) < 1e-12);
  for (const Vec3& w : {normalized({0.3, -0.5, 0.6}), normalized({-0.9, 0.1, -0.2}), normalized({0.1, 0.95, 0.05})}) {
    guide_angles(w, th, ph);
    const Vec3 back = guide_direction(th, ph);
    for (std::size_t i = 0; i < 3; ++i) CHECK(back[i] == Approx(w[i]).margin(1e-12));
  }
}

TEST_CASE("a leaf's grid holds the incident luminance integrated over each cell's solid angle", "[guide]") {
  std::vector<Sample> s;
  add_samples(s, 200000, {0, 0, 0}, {0, 0, 1}, 0.3, 1.0, 7);  // L = 1 everywhere
  const std::vector<double> g = bin_leaf(s.data(), s.data() + s.size(), 8, 16);
  double total = 0;
  for (int i = 0; i < 8; ++i) {
    // a cell's solid angle: (sin(theta_hi) - sin(theta_lo)) dphi
    const double th0 = -kPi / 2 + i * kPi / 8, omega = (std::sin(th0 + kPi / 8) - std::sin(th0)) * 2 * kPi / 16;
    for (int j = 0; j < 16; ++j) {
      const double v = g[std::size_t(i * 16 + j)];
      total += v;
      CHECK(v == Approx(omega).epsilon(0.12));
    }
  }
  CHECK(total == Approx(4 * kPi).epsilon(0.002));
}

TEST_CASE("the learned mixture recovers a small emitter over a dim background", "[guide]") {
  Progress::set_enabled(false);
  const Vec3 toward = normalized({0.3, -0.5, 0.6});
  const double radius = 0.2, emitter = 60;
  std::vector<Sample> s;
  add_samples(s, 60000, {0, 0, 0}, toward, radius, emitter, 11);
  FieldSettings fs = settings();
  fs.leaf_samples = 1 << 20;  // one leaf
  RadianceField field;
  field.learn(s, fs, select_devices(""), "guide_test");
  REQUIRE(field.leaves() == 1);
  REQUIRE(field.fitted() == 1);
  const Leaf* leaf = field.at({0.5, 0.5, 0.5});
  REQUIRE(leaf != nullptr);
  // the emitter's share of the incident power: emitter x its solid angle over the total
  const double cap = 2 * kPi * (1 - std::cos(radius));
  const double share = emitter * cap / (emitter * cap + (4 * kPi - cap));
  // the mixture's mass near the emitter (within a grid cell of its edge, which the grid
  // blurs by a cell) against the share
  const double near = mass_near(leaf->mixture, toward, radius + kPi / fs.grid_theta);
  std::printf("guide_test: emitter share %.3f, the mixture's mass near it %.3f (K %zu)\n", share, near,
              leaf->mixture.components.size());
  CHECK(near > share - 0.08);
  CHECK(near < share + 0.12);
  // and per steradian it is brightest toward the emitter
  double th, ph, th2, ph2;
  guide_angles(toward, th, ph);
  guide_angles(neg(toward), th2, ph2);
  const double at = leaf->mixture.pdf_omega(mix::Domain::Fiber, th, ph);
  const double away = leaf->mixture.pdf_omega(mix::Domain::Fiber, th2, ph2);
  CHECK(at > 20 * away);
}

TEST_CASE("a leaf guides where its guide lowers the second moment, and not where it raises it", "[guide]") {
  Progress::set_enabled(false);
  const Vec3 toward = normalized({0.3, -0.5, 0.6});
  std::vector<Sample> s;
  add_samples(s, 40000, {0, 0, 0}, toward, 0.2, 200, 5);
  // a guide toward the emitter (and a broad part) lowers it: the largest share
  mix::SliceMixture good;
  mix::Gaussian g;
  guide_angles(toward, g.mu_t, g.mu_p);
  g.weight = 0.8;
  g.s_tt = g.s_pp = 0.04;
  mix::Gaussian broad = g;
  broad.weight = 0.2;
  broad.s_tt = broad.s_pp = 4;
  good.components = {g, broad};
  good.prepare();
  CHECK(best_share(good, s.data(), s.data() + s.size(), 0.5) == Approx(0.5));
  // a guide pointing away from it raises it: none
  mix::SliceMixture bad = good;
  guide_angles(neg(toward), bad.components[0].mu_t, bad.components[0].mu_p);
  bad.components[1].weight = 1e-3;
  bad.prepare();
  CHECK(best_share(bad, s.data(), s.data() + s.size(), 0.5) == 0);
}

TEST_CASE("the kd-tree keeps two regions with different light apart", "[guide]") {
  Progress::set_enabled(false);
  const Vec3 up{0, 0, 1}, side = normalized({1, 0, 0.2});
  std::vector<Sample> s;
  add_samples(s, 20000, {0, 0, 0}, up, 0.25, 80, 3);
  add_samples(s, 20000, {5, 0, 0}, side, 0.25, 80, 4);
  FieldSettings fs = settings();
  fs.leaf_samples = 25000;  // one split
  RadianceField field;
  field.learn(s, fs, select_devices(""), "guide_test");
  REQUIRE(field.leaves() == 2);
  REQUIRE(field.fitted() == 2);
  const Leaf* a = field.at({0.5, 0.5, 0.5});
  const Leaf* b = field.at({5.5, 0.5, 0.5});
  REQUIRE(a != nullptr);
  REQUIRE(b != nullptr);
  REQUIRE(a != b);
  CHECK(mass_near(a->mixture, up, 0.45) > mass_near(a->mixture, side, 0.45) + 0.3);
  CHECK(mass_near(b->mixture, side, 0.45) > mass_near(b->mixture, up, 0.45) + 0.3);
  // a leaf with fewer vertices than min_vertices has no mixture
  fs.min_vertices = 30000;
  field.learn(s, fs, select_devices(""), "guide_test");
  CHECK(field.fitted() == 0);
  CHECK(field.at({0.5, 0.5, 0.5}) == nullptr);
}
