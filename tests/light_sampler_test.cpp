// Light sampling of convergence scenes (host/sampling/light_sampler.cpp): for a constant,
// a sharp and a broad lobe, a tilted sky gradient, an environment map and all of them
// together, the pdf integrating to 1 over the sphere, Pearson chi-square of samples
// against the pdf (equal-area world bins, and bins around a sharp lobe), unit samples and
// a positive pdf wherever the radiance is positive; the ConfigErrors of
// make_light_sampler; term probabilities proportional to the terms' powers; and
// world_to_slice inverting Lighting::to_world.
// labels: sample
#include <catch2/catch.hpp>

#include "chi_square.hpp"

#include <bsdfmix/mixture.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "core/vec3.hpp"
#include "sampling/light_sampler.hpp"
#include "sampling/lighting.hpp"

using namespace bsdfmix;

namespace {

// Fixed seed (printed); LIGHT_TEST_SEED overrides it to re-check with other streams.
const std::uint64_t kSeed = std::getenv("LIGHT_TEST_SEED") ? std::strtoull(std::getenv("LIGHT_TEST_SEED"), nullptr, 10)
                                                            : 20240611ull;

// Unit direction from z = cos(polar) and azimuth (the env map's and the world bins' frame).
Vec3 from_z_az(double z, double az) {
  const double r = std::sqrt(std::max(0.0, 1 - z * z));
  return {r * std::cos(az), r * std::sin(az), z};
}

const double kGx[8] = {-0.9602898564975363, -0.7966664774136267, -0.5255324099163290, -0.1834346424956498,
                       0.1834346424956498,  0.5255324099163290,  0.7966664774136267,  0.9602898564975363};
const double kGw[8] = {0.1012285362903763, 0.2223810344533745, 0.3137066278286366, 0.3626837833783620,
                       0.3626837833783620, 0.3137066278286366, 0.2223810344533745, 0.1012285362903763};

// Integral of f over [x0, x1] x [y0, y1]: n x n panels of Gauss-Legendre 8 x 8.
double gl2(const std::function<double(double, double)>& f, double x0, double x1, double y0, double y1, int n) {
  double s = 0;
  for (int a = 0; a < n; ++a)
    for (int b = 0; b < n; ++b) {
      const double xa = x0 + (x1 - x0) * a / n, xb = x0 + (x1 - x0) * (a + 1) / n;
      const double ya = y0 + (y1 - y0) * b / n, yb = y0 + (y1 - y0) * (b + 1) / n;
      double t = 0;
      for (int i = 0; i < 8; ++i)
        for (int j = 0; j < 8; ++j)
          t += kGw[i] * kGw[j] * f(0.5 * (xa + xb) + 0.5 * (xb - xa) * kGx[i], 0.5 * (ya + yb) + 0.5 * (yb - ya) * kGx[j]);
      s += t * 0.25 * (xb - xa) * (yb - ya);
    }
  return s;
}

// An environment map (32 x 16): smooth background, a bright 1-pixel sun at (x 5, y 9),
// and the two bottom rows black (so the radiance is zero on part of the sphere).
void add_env(Lighting& l) {
  const int W = 32, H = 16;
  l.env_width = W;
  l.env_height = H;
  l.env_scale = 1;
  l.env.assign(std::size_t(W * H), 0.f);
  for (int y = 0; y < H - 2; ++y)
    for (int x = 0; x < W; ++x) {
      const double polar = kPi * (y + 0.5) / H, az = -kPi + 2 * kPi * (x + 0.5) / W;
      l.env[std::size_t(y * W + x)] = float(0.2 + 0.12 * std::cos(az) * std::sin(polar) + 0.05 * std::cos(polar));
    }
  l.env[std::size_t(9 * W + 5)] = 40.f;
}

const Vec3 kSharpDir = normalized({0.3, 0.5, 0.8});
const double kSharpKappa = std::log(2.0) / (1 - std::cos(4 * kPi / 180));  // 4 degrees half-max radius

LightLobe sharp_lobe(double radiance) {
  LightLobe lb;
  lb.direction = kSharpDir;
  lb.kappa = kSharpKappa;
  lb.radiance = radiance;
  return lb;
}
LightLobe broad_lobe(double radiance) {
  LightLobe lb;
  lb.direction = normalized({-0.6, 0.2, -0.77});
  lb.kappa = 3;
  lb.radiance = radiance;
  return lb;
}
void add_gradient(Lighting& l) {
  l.gradient = true;
  l.zenith = 1;
  l.horizon = 0.5;
  l.ground = 0.1;
  l.up = normalized({0.3, -0.2, 0.93});
}

struct Scene {
  std::string name;
  Lighting light;
  bool sharp = false;  // has the sharp lobe: also test in bins around it
};

std::vector<Scene> scenes() {
  std::vector<Scene> out;
  auto base = [](const std::string& name, double c) {
    Lighting l = default_lighting(Domain::Fiber, c);
    l.name = name;
    return l;
  };
  Scene s;
  s = {"constant", base("constant", 0.7), false};
  out.push_back(s);
  s = {"sharp lobe", base("sharp lobe", 0.0), true};
  s.light.lobes.push_back(sharp_lobe(10));
  out.push_back(s);
  s = {"broad lobe", base("broad lobe", 0.0), false};
  s.light.lobes.push_back(broad_lobe(2));
  out.push_back(s);
  s = {"gradient", base("gradient", 0.0), false};
  add_gradient(s.light);
  out.push_back(s);
  s = {"env map", base("env map", 0.0), false};
  add_env(s.light);
  out.push_back(s);
  s = {"all", base("all", 0.05), true};
  s.light.lobes.push_back(sharp_lobe(300));
  s.light.lobes.push_back(broad_lobe(0.5));
  add_gradient(s.light);
  add_env(s.light);
  out.push_back(s);
  return out;
}

// The pdf's integral over the sphere: a midpoint grid in (polar angle, azimuth) of
// 1600 x 3200 cells (each env pixel exactly 100 x 100 cells), each weighted by its exact
// solid angle; about 30 cells per standard deviation of the sharp lobe.
double sphere_integral(const LightSampler& s) {
  const int np = 1600, na = 3200;
  double total = 0;
  for (int i = 0; i < np; ++i) {
    const double t0 = kPi * i / np, t1 = kPi * (i + 1) / np, tm = 0.5 * (t0 + t1);
    const double omega = (std::cos(t0) - std::cos(t1)) * 2 * kPi / na;
    const double z = std::cos(tm);
    double row = 0;
    for (int j = 0; j < na; ++j) row += s.pdf(from_z_az(z, -kPi + 2 * kPi * (j + 0.5) / na));
    total += row * omega;
  }
  return total;
}

struct Chi2 {
  double stat = 0, p = 0, mass = 0;
  int dof = 0;
};

Chi2 pearson(const std::vector<double>& obs, const std::vector<double>& expct) {
  const bsdfmix::test::ChiSquare c = bsdfmix::test::pearson(obs, expct);
  Chi2 r;
  r.stat = c.stat;
  r.p = c.p;
  r.dof = c.dof;
  return r;
}

std::vector<Vec3> draw(const LightSampler& s, std::uint32_t stream, std::size_t n) {
  std::vector<Vec3> out(n);
  for (std::size_t i = 0; i < n; ++i) {
    double u[4];
    mix::uniforms(kSeed, stream, i, u);
    out[i] = s.sample(u[0], u[1], u[2], u[3]);
  }
  return out;
}

// World bins: 24 equal-area bands in z times 48 in azimuth; each bin's expected mass by
// Gauss-Legendre on the pieces between the env map's pixel edges (where its density
// jumps), so the map's piecewise constant density is integrated exactly.
Chi2 chi2_world(const LightSampler& s, const std::vector<Vec3>& w) {
  const int nz = 24, na = 48;
  std::vector<double> obs(std::size_t(nz * na), 0.0), expct(obs.size(), 0.0);
  for (const Vec3& v : w) {
    const int i = std::clamp(int((v[2] + 1) / 2 * nz), 0, nz - 1);
    const int j = std::clamp(int((std::atan2(v[1], v[0]) + kPi) / (2 * kPi) * na), 0, na - 1);
    obs[std::size_t(i * na + j)] += 1;
  }
  const auto f = [&](double z, double az) { return s.pdf(from_z_az(z, az)); };
  const int W = s.env_w, H = s.env_h;
  Chi2 r;
  for (int i = 0; i < nz; ++i) {
    const double z0 = -1 + 2.0 * i / nz, z1 = -1 + 2.0 * (i + 1) / nz;
    std::vector<double> zs{z0};
    for (int y = H - 1; y >= 1; --y) {  // pixel row edges, increasing z
      const double ze = std::cos(kPi * y / H);
      if (ze > z0 && ze < z1) zs.push_back(ze);
    }
    zs.push_back(z1);
    for (int j = 0; j < na; ++j) {
      const double a0 = -kPi + 2 * kPi * j / na, a1 = -kPi + 2 * kPi * (j + 1) / na;
      std::vector<double> as{a0};
      for (int x = 1; x < W; ++x) {
        const double ae = -kPi + 2 * kPi * x / W;
        if (ae > a0 && ae < a1) as.push_back(ae);
      }
      as.push_back(a1);
      double m = 0;
      for (std::size_t p = 0; p + 1 < zs.size(); ++p)
        for (std::size_t q = 0; q + 1 < as.size(); ++q) m += gl2(f, zs[p], zs[p + 1], as[q], as[q + 1], 3);
      r.mass += m;
      expct[std::size_t(i * na + j)] = m * double(w.size());
    }
  }
  const double mass = r.mass;
  r = pearson(obs, expct);
  r.mass = mass;
  return r;
}

// Bins around the sharp lobe's direction d: 16 rings in s = 1 - dot(w, d) at the lobe
// term's quantiles 0, 0.95/16, ..., 0.95 (a cap of about 8.3 degrees) times 32 azimuths
// around d, and one bin for the rest of the sphere (expecting N (1 - the cap's mass)).
Chi2 chi2_lobe(const LightSampler& s, const std::vector<Vec3>& w) {
  const int nr = 16, na = 32;
  const Vec3 d = kSharpDir;
  const Vec3 t1 = normalized(cross(d, {1, 0, 0})), t2 = cross(d, t1);
  std::vector<double> edge(nr + 1);
  for (int i = 0; i <= nr; ++i)
    edge[std::size_t(i)] = -std::log(1 - 0.95 * i / nr * (1 - std::exp(-2 * kSharpKappa))) / kSharpKappa;
  std::vector<double> obs(std::size_t(nr * na + 1), 0.0), expct(obs.size(), 0.0);
  for (const Vec3& v : w) {
    const double sv = 1 - dot(v, d);
    if (sv >= edge.back()) {
      obs.back() += 1;
      continue;
    }
    const int i = std::clamp(int(std::upper_bound(edge.begin(), edge.end(), sv) - edge.begin()) - 1, 0, nr - 1);
    const int j = std::clamp(int((std::atan2(dot(v, t2), dot(v, t1)) + kPi) / (2 * kPi) * na), 0, na - 1);
    obs[std::size_t(i * na + j)] += 1;
  }
  const auto f = [&](double sv, double psi) {
    const double r = std::sqrt(std::max(0.0, sv * (2 - sv))), c = std::cos(psi), sn = std::sin(psi);
    Vec3 v;
    for (int k = 0; k < 3; ++k) v[std::size_t(k)] = (1 - sv) * d[std::size_t(k)] + r * (c * t1[std::size_t(k)] + sn * t2[std::size_t(k)]);
    return s.pdf(v);  // d(omega) = ds dpsi
  };
  double cap = 0;
  for (int i = 0; i < nr; ++i)
    for (int j = 0; j < na; ++j) {
      const double m = gl2(f, edge[std::size_t(i)], edge[std::size_t(i + 1)], -kPi + 2 * kPi * j / na,
                           -kPi + 2 * kPi * (j + 1) / na, 2);
      cap += m;
      expct[std::size_t(i * na + j)] = m * double(w.size());
    }
  expct.back() = std::max(0.0, 1 - cap) * double(w.size());
  Chi2 r = pearson(obs, expct);
  r.mass = cap;
  return r;
}

std::string error_of(const Lighting& l) {
  try {
    make_light_sampler(l);
  } catch (const ConfigError& e) {
    return e.what();
  } catch (const std::exception& e) {
    return std::string("not a ConfigError: ") + e.what();
  }
  return "no error";
}

}  // namespace

TEST_CASE("light sampler: the pdf integrates to 1, samples follow it (chi-square), radiance > 0 implies pdf > 0",
          "[sample][light]") {
  std::uint32_t stream = 100;
  for (const Scene& sc : scenes()) {
    const LightSampler s = make_light_sampler(sc.light);
    std::printf("light_sampler_test: %s: p_const %.4f, p_grad %.4f, p_env %.4f, p_lobe", sc.name.c_str(), s.p_const,
                s.p_grad, s.p_env);
    for (const double p : s.p_lobe) std::printf(" %.4f", p);
    std::printf("\n");
    INFO("scene " << sc.name << ", seed " << kSeed);

    // (i) the pdf integrates to 1 over the sphere
    const double integral = sphere_integral(s);
    std::printf("light_sampler_test: %s: integral of the pdf over the sphere %.8f\n", sc.name.c_str(), integral);
    CHECK(std::abs(integral - 1) < 1e-3);

    // (ii) chi-square of 200000 samples
    const std::size_t n = 200000;
    const std::vector<Vec3> w = draw(s, stream++, n);
    const Chi2 cw = chi2_world(s, w);
    std::printf("light_sampler_test: %s: chi2 world 24 x 48 bins: seed %llu, chi2 %.1f, dof %d, p-value %.4f, bin mass "
                "%.6f\n",
                sc.name.c_str(), (unsigned long long)kSeed, cw.stat, cw.dof, cw.p, cw.mass);
    CHECK(cw.p > 0.01);
    CHECK(std::abs(cw.mass - 1) < 1e-4);
    if (sc.sharp) {
      const Chi2 cl = chi2_lobe(s, w);
      std::printf("light_sampler_test: %s: chi2 around the sharp lobe 16 x 32 + 1 bins: seed %llu, chi2 %.1f, dof %d, "
                  "p-value %.4f, cap mass %.6f\n",
                  sc.name.c_str(), (unsigned long long)kSeed, cl.stat, cl.dof, cl.p, cl.mass);
      CHECK(cl.p > 0.01);
      CHECK(cl.dof > 300);  // the cap's bins are populated: the test has power on the lobe
    }

    // (iii) unit samples with a positive pdf; radiance > 0 implies pdf > 0
    double worst_norm = 0;
    std::size_t zero_pdf = 0;
    for (const Vec3& v : w) {
      worst_norm = std::max(worst_norm, std::abs(std::sqrt(dot(v, v)) - 1));
      const double p = s.pdf(v);
      if (!(p > 0) || !std::isfinite(p)) ++zero_pdf;
    }
    std::size_t lit = 0, unlit = 0, missed = 0, negative = 0;
    for (std::size_t i = 0; i < n; ++i) {
      double u[4];
      mix::uniforms(kSeed, 999, i, u);
      const Vec3 v = from_z_az(1 - 2 * u[0], -kPi + 2 * kPi * u[1]);
      const double L = sc.light.radiance_world(v), p = s.pdf(v);
      if (!(p >= 0)) ++negative;
      if (L > 0) {
        ++lit;
        if (!(p > 0)) ++missed;
      } else {
        ++unlit;
      }
    }
    std::printf("light_sampler_test: %s: worst | |w| - 1 | %.2e, samples with pdf <= 0: %zu; random directions lit %zu, "
                "unlit %zu, lit with pdf 0: %zu\n",
                sc.name.c_str(), worst_norm, zero_pdf, lit, unlit, missed);
    CHECK(worst_norm < 1e-12);
    CHECK(zero_pdf == 0);
    CHECK(missed == 0);
    CHECK(negative == 0);
    if (sc.name == "env map") CHECK(unlit > 0);  // the black rows: the check sees L = 0 too
  }
}

TEST_CASE("make_light_sampler: ConfigError for a negative term or no power, naming the scene", "[sample][light]") {
  Lighting g = default_lighting(Domain::Fiber, 0.5);
  g.name = "neg-gradient";
  add_gradient(g);
  g.horizon = -0.1;
  const std::string eg = error_of(g);
  Lighting lb = default_lighting(Domain::Hemisphere, 0.5);
  lb.name = "neg-lobe";
  lb.lobes.push_back(sharp_lobe(-1));
  const std::string el = error_of(lb);
  Lighting dark = default_lighting(Domain::Fiber, 0.0);
  dark.name = "dark";
  const std::string ed = error_of(dark);
  std::printf("light_sampler_test: errors: \"%s\" | \"%s\" | \"%s\"\n", eg.c_str(), el.c_str(), ed.c_str());
  CHECK_THAT(eg, Catch::Contains("scene 'neg-gradient'") && Catch::Contains("gradient"));
  CHECK_THAT(el, Catch::Contains("scene 'neg-lobe'") && Catch::Contains("lobe"));
  CHECK_THAT(ed, Catch::Contains("scene 'dark'") && Catch::Contains("no power"));
  CHECK_THROWS_AS(make_light_sampler(g), ConfigError);
  CHECK_THROWS_AS(make_light_sampler(lb), ConfigError);
  CHECK_THROWS_AS(make_light_sampler(dark), ConfigError);
  // a gradient of zeros and a black map add no power either
  Lighting zero = dark;
  zero.name = "zero terms";
  add_gradient(zero);
  zero.zenith = zero.horizon = zero.ground = 0;
  add_env(zero);
  std::fill(zero.env.begin(), zero.env.end(), 0.f);
  CHECK_THAT(error_of(zero), Catch::Contains("scene 'zero terms'") && Catch::Contains("no power"));
}

TEST_CASE("make_light_sampler: term probabilities are proportional to the terms' powers", "[sample][light]") {
  for (const double k : {1e-3, 3.0, kSharpKappa}) {
    const double c = 0.3, R = 5;
    Lighting l = default_lighting(Domain::Fiber, c);
    l.name = "powers";
    LightLobe lb = sharp_lobe(R);
    lb.kappa = k;
    l.lobes.push_back(lb);
    const LightSampler s = make_light_sampler(l);
    const double expect = (4 * kPi * c) / (R * 2 * kPi * (1 - std::exp(-2 * k)) / k);
    const double got = s.p_const / s.p_lobe[0];
    std::printf("light_sampler_test: kappa %.6g: p_const / p_lobe %.15g, expected %.15g, rel %.2e\n", k, got, expect,
                std::abs(got / expect - 1));
    INFO("kappa " << k);
    CHECK(std::abs(got / expect - 1) < 1e-12);
    CHECK(std::abs(s.p_const + s.p_lobe[0] - 1) < 1e-15);
    CHECK(s.p_grad == 0);
    CHECK(s.p_env == 0);
  }
}

TEST_CASE("world_to_slice inverts Lighting::to_world in both domains", "[sample][light]") {
  Lighting tilted = default_lighting(Domain::Hemisphere);
  set_frame(tilted, {0.2, -0.5, 0.8}, {1, 1, 0}, "tilted");
  const Lighting ls[3] = {default_lighting(Domain::Fiber), default_lighting(Domain::Hemisphere), tilted};
  const char* names[3] = {"fiber", "hemisphere", "hemisphere, tilted frame"};
  for (int k = 0; k < 3; ++k) {
    const Lighting& l = ls[k];
    const double lo = l.domain == Domain::Fiber ? -kPi / 2 : 0.0, hi = kPi / 2;
    // asin / acos of dot(w, axis) are ill-conditioned at the poles (J -> 0): the error is
    // about 1e-16 / J there, so within ~2e-3 rad of a pole the bound is 2e-15 / J.
    double worst_t = 0, worst_p = 0, worst_scaled = 0;
    std::size_t bad = 0, near_pole = 0;
    const std::size_t n = 20000;
    for (std::size_t i = 0; i < n; ++i) {
      double u[4];
      mix::uniforms(kSeed, 500 + std::uint32_t(k), i, u);
      const double theta = lo + (hi - lo) * u[0], phi = -kPi + 2 * kPi * u[1];
      double t2 = 0, p2 = 0;
      world_to_slice(l, l.to_world(theta, phi), t2, p2);
      const double dt = std::abs(t2 - theta), dp = std::abs(mix::wrap_phi(p2 - phi));
      const double J = std::abs(l.domain == Domain::Fiber ? std::cos(theta) : std::sin(theta));
      const double bound = std::max(1e-12, 2e-15 / J);
      near_pole += bound > 1e-12;
      if (!(dt < bound) || !(dp < bound) || !(p2 >= -kPi) || !(p2 < kPi)) ++bad;
      worst_t = std::max(worst_t, dt);
      worst_p = std::max(worst_p, dp);
      worst_scaled = std::max(worst_scaled, std::max(dt, dp) * J);
    }
    std::printf("light_sampler_test: world_to_slice(to_world) %s: %zu points (%zu within 2e-3 of a pole), worst "
                "|dtheta| %.2e, |dphi| %.2e, worst error * J %.2e, out of bound %zu\n",
                names[k], n, near_pole, worst_t, worst_p, worst_scaled, bad);
    INFO(names[k]);
    CHECK(bad == 0);
  }
}
