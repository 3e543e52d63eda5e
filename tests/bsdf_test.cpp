// The renderer's BSDF interface (render/bsdf.hpp, render/bxdf.hpp): at a fiber, a measured
// surface and the ground, a drawn direction's density is the one pdf() gives there, the
// densities integrate to one over the domain, and the ground's cosine draw weighs every
// direction by the albedo.
// labels: render
#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>

#include "io/table.hpp"
#include "render/bsdf.hpp"
#include "sampling/sampling.hpp"

using namespace bsdfmix;
using namespace bsdfmix::render;
namespace fs = std::filesystem;

namespace {

// A table of the domain with a lobe about the mirror direction over a floor.
std::string lobe_table(Domain d) {
  const fs::path dir = fs::temp_directory_path() / "bsdfmix_bsdf_test";
  fs::create_directories(dir);
  const std::string path = (dir / (d == Domain::Fiber ? "fiber.h5" : "surface.h5")).string();
  const TableMeta meta = make_grid(d, 4, 1, 24, 48, true);
  std::vector<float> values;
  for (const double to : meta.theta_o)
    for (const double th : meta.theta_i)
      for (const double ph : meta.phi_i) {
        const double dt = th - (d == Domain::Fiber ? -to : to), dp = wrap_phi(ph - kPi);
        values.push_back(float(0.05 + std::exp(-0.5 * (dt * dt + dp * dp) / 0.09)));
      }
  write_table(path, meta, values);
  return path;
}

double uniforms(std::uint64_t n, int i) {
  double u[4];
  run_uniforms(7, 0x62736466u, 0, n, u);
  return u[i];
}

// Draws n directions: each one's reported density equals pdf() there; returns the mean of
// 1 / pdf over uniform directions of the sphere times pdf (the density's integral).
double check_bsdf(const Bsdf& b, int n) {
  int drawn = 0;
  for (int s = 0; s < n; ++s) {
    const double u[4] = {uniforms(std::uint64_t(s), 0), uniforms(std::uint64_t(s), 1), uniforms(std::uint64_t(s), 2),
                         uniforms(std::uint64_t(s), 3)};
    Vec3 wi;
    double pdf = 0;
    if (!b.sample(u, wi, pdf)) continue;
    ++drawn;
    REQUIRE(std::abs(dot(wi, wi) - 1) < 1e-9);
    CHECK(b.pdf(wi) == Approx(pdf).epsilon(1e-6));
  }
  CHECK(drawn > n / 2);
  double integral = 0;
  const int m = 200000;
  for (int s = 0; s < m; ++s) {
    const double z = 2 * uniforms(std::uint64_t(n + s), 0) - 1, a = 2 * kPi * uniforms(std::uint64_t(n + s), 1);
    const double r = std::sqrt(std::max(0.0, 1 - z * z));
    integral += b.pdf({r * std::cos(a), r * std::sin(a), z}) * 4 * kPi / m;
  }
  return integral;
}

}  // namespace

TEST_CASE("a fiber's and a measured surface's Bsdf draw with the density pdf() gives, which integrates to one",
          "[render]") {
  for (const Domain d : {Domain::Fiber, Domain::Hemisphere}) {
    const TableBsdf table(lobe_table(d));
    for (const BsdfSampler t : {BsdfSampler::Uniform, BsdfSampler::TableCdf}) {
      PathStrategy st;
      st.technique = t;
      const SampledBxdf bxdf(table, FSource::Table, st);
      const Vec3 axis = normalized({0.2, 0.3, 1.0}), wo = normalized({0.6, -0.2, 0.7});
      Hit hit;
      hit.kind = d == Domain::Fiber ? HitKind::Fiber : HitKind::Surface;
      hit.tangent = hit.normal = axis;
      VertexBsdf held;
      const Bsdf& b = held.at(hit, wo, bxdf, 0.5);
      REQUIRE(b.tabulated());
      INFO(domain_name(d) << " technique " << int(t));
      CHECK(check_bsdf(b, 2000) == Approx(1).epsilon(0.02));
      // the integrand's factor: f, times the cosine on a surface (zero below it)
      const double c = d == Domain::Fiber ? 1.0 : std::cos(0.4);
      const Vec3 w = local_direction(b.axes(), 0.4, 2.5);
      CHECK(b.f(w)[0] == Approx(table.f(FSource::Table, b.theta_o(), 0.4, 2.5) * c).epsilon(1e-9));
    }
  }
}

TEST_CASE("the ground's Lambertian: cosine draws weighted by the albedo", "[render]") {
  const Vec3 n = normalized({0.1, -0.2, 1.0});
  const Lambertian ground(0.4, n);
  CHECK_FALSE(ground.tabulated());
  CHECK(check_bsdf(ground, 2000) == Approx(1).epsilon(0.02));
  for (int s = 0; s < 100; ++s) {
    const double u[4] = {0, 0, uniforms(std::uint64_t(s), 2), uniforms(std::uint64_t(s), 3)};
    Vec3 wi;
    double pdf = 0;
    REQUIRE(ground.sample(u, wi, pdf));
    CHECK(dot(wi, n) > 0);
    CHECK(ground.f(wi)[1] / pdf == Approx(0.4).epsilon(1e-9));
  }
  CHECK(ground.f(neg(n)).max() == 0);
}
