// The path tracer of `bsdfmix render` (host/render/): a white furnace (lossless fibers
// under a constant environment render 1), every path estimator unbiased (image means over
// independent seeds agree), the table lookup against the fiber generator, the renderer's
// samplers against the study's (the header's MixtureSet::sample and pdf_omega) and their
// pdfs' mass, the stand-in render against the table render, reproducibility for a seed
// whatever the thread count, bad render configs rejected with one line, and a measured
// sphere sampled with its RGL file's warps (is_rgl, mis_light_rgl) against mis_light_cdf.
// labels: render
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <tuple>

#include "config/config.hpp"
#include "core/error.hpp"
#include "core/progress.hpp"
#include "io/mixture_file.hpp"
#include "device/device.hpp"
#include "render/guide_training.hpp"
#include "render/integrator.hpp"
#include "render/render_run.hpp"
#include "render/surface.hpp"
#include "sweep/sweep.hpp"
#include "tables/fiber_generator.hpp"
#include "tables/rgl_brdf.hpp"
#include "tables/rgl_import.hpp"

using namespace bsdfmix;
using namespace bsdfmix::render;
namespace fs = std::filesystem;

namespace {

fs::path temp_dir() {
  const fs::path d = fs::temp_directory_path() / "bsdfmix_render_test";
  fs::create_directories(d);
  return d;
}

// A small fiber table of a preset, tabulated on the CPU (18 theta_o x 30 x 60 cells), the
// luminance alone (the color tests add their own `rgb`). Kept in the temp directory while
// its source (the generator's parameters, the model included) is the current one.
std::string small_table(const std::string& preset) {
  const std::string path = (temp_dir() / (preset + "_table.h5")).string();
  FiberGenerateOptions opt;
  opt.preset = preset;
  opt.n_theta_o = 18;
  opt.n_theta_i = 30;
  opt.n_phi_i = 60;
  opt.h_nodes = 64;
  TableMeta meta = fiber_table_meta(opt);
  meta.source = fiber_source_json(opt);
  meta.rgb = false;
  if (fs::exists(path) && TableReader(path).meta().source == meta.source) return path;
  const FiberModel model = fiber_model_for(opt);
  std::vector<float> values;
  for (std::size_t t = 0; t < meta.theta_o.size(); ++t) {
    const std::vector<double> s = tabulate_fiber_slice_cpu(model, meta, t, 0);
    for (double v : s) values.push_back(float(v));
  }
  write_table(path, meta, values);
  return path;
}

// The same table with an `rgb` channel of `color` times f in each channel (a grey table
// when color is (1, 1, 1)).
std::string colored_table(const std::string& preset, const double color[3], const std::string& name) {
  // always rewritten from the current small table
  const std::string path = (temp_dir() / (preset + "_" + name + "_rgb_table.h5")).string();
  const TableReader plain(small_table(preset));
  TableMeta meta = plain.meta();
  meta.rgb = true;
  TableWriter w(path, meta);
  for (std::size_t t = 0; t < meta.theta_o.size(); ++t) {
    const std::vector<float> v = plain.read_slice(t, 0);
    std::vector<float> rgb(3 * v.size());
    for (std::size_t i = 0; i < v.size(); ++i)
      for (int c = 0; c < 3; ++c) rgb[3 * i + std::size_t(c)] = float(double(v[i]) * color[c]);
    w.write_slice(t, 0, v.data(), rgb.data());
  }
  w.commit();
  return path;
}

// The table's mixtures, fitted by the sweep (K <= 8), cached in the temp directory.
mix::MixtureSet fitted_mixture(const std::string& table) {
  const std::string out = table + ".mixture.h5";
  if (!fs::exists(out) || read_mixture_file(out).table_source != TableReader(table).meta().source) {
    FitSection fit;
    fit.output = out;
    fit.report = table + ".fit.csv";
    fit.search_report = table + ".search.csv";
    fit.k_max = 8;
    fit.restarts = 1;
    fit.final_restarts = 1;
    run_sweep(table, fit, "");
  }
  return to_mixture_set(read_mixture_file(out));
}

// A mixture per theta_o slice: one broad Gaussian and one around the specular cone
// (theta_i = -theta_o): any mixture serves the samplers, whose pdf is exact.
mix::MixtureSet broad_mixture(const TableMeta& meta) {
  mix::MixtureSet set;
  set.domain = mix::Domain::Fiber;
  set.azimuthal = true;
  set.grid_theta_o = meta.theta_o;
  set.grid_phi_o = meta.phi_o;
  for (double to : meta.theta_o) {
    mix::SliceMixture s;
    s.theta_o = to;
    s.scale = 1;
    mix::Gaussian a, b;
    a.weight = 0.6;
    a.mu_t = -to;
    a.s_tt = 0.05;
    a.s_pp = 2.0;
    b.weight = 0.4;
    b.s_tt = 0.6;
    b.s_pp = 6.0;
    s.components = {a, b};
    set.slices.push_back(s);
  }
  set.prepare();
  return set;
}

struct Scene {
  Cloth cloth;
  std::unique_ptr<Tracer> tracer;
  Lighting lighting;
  LightSampler light;
  std::vector<mix::Gaussian> world_light;  // mis_product's: any mixture serves, its pdf is exact
  SceneView view;
};

// A world lighting mixture for mis_product (render/light_carry.hpp): a compact component
// at each lobe of the lighting (or, without lobes, one up high), with a broad one that
// compact_components leaves out.
std::vector<mix::Gaussian> world_mixture(const Lighting& l) {
  mix::SliceMixture m;
  auto add = [&](double w, const Vec3& d, double sigma) {
    mix::Gaussian g;
    g.weight = w;
    local_angles(kWorldAxes, d, g.mu_t, g.mu_p);
    g.s_tt = sigma * sigma;
    g.s_pp = sigma * sigma / std::max(0.05, std::cos(g.mu_t) * std::cos(g.mu_t));
    m.components.push_back(g);
  };
  for (const LightLobe& lb : l.lobes) add(1.0, lb.direction, 0.06);
  if (l.lobes.empty()) add(1.0, normalized({0.2, -0.6, 0.5}), 0.15);
  add(0.5, {0, 0, 1}, 1.2);
  m.prepare();
  const std::vector<mix::Gaussian> compact = compact_components(m);
  REQUIRE(compact.size() == std::max<std::size_t>(l.lobes.size(), 1));
  return compact;
}

std::unique_ptr<Scene> make_scene(const TableBsdf& bsdf, const Lighting& lighting, bool ground, int size) {
  auto s = std::make_unique<Scene>();
  ClothParams p;
  p.yarn_spacing = 0.1;
  p.yarn_radius = 0.04;
  p.fibers_per_ply = 6;
  p.fiber_radius = 0.006;
  s->cloth = make_cloth(p, "test cloth");
  GroundPlane g;
  g.enabled = ground;
  g.z = -0.06;
  g.half = 4;
  s->tracer = std::make_unique<Tracer>(s->cloth, g);
  s->lighting = lighting;
  s->light = make_light_sampler(lighting);
  s->world_light = world_mixture(lighting);
  SceneView& v = s->view;
  v.world_light = &s->world_light;
  v.tracer = s->tracer.get();
  v.bsdf = &bsdf;
  v.lighting = &s->lighting;
  v.light = &s->light;
  v.camera.position = {0, -0.35, 0.5};
  v.camera.look_at = {0, 0, 0};
  v.camera.fov_deg = 30;
  v.fiber_radius = p.fiber_radius;
  v.width = v.height = size;
  v.max_depth = 200;
  v.rr_depth = 3;
  v.threads = 2;
  return s;
}

Lighting sky() {
  Lighting l = default_lighting(Domain::Hemisphere, 0.1);
  l.name = "sky";
  LightLobe sun;
  sun.direction = {0.35, 0.25, std::sqrt(1 - 0.35 * 0.35 - 0.25 * 0.25)};
  sun.kappa = std::log(2.0) / (1 - std::cos(6 * kPi / 180));
  sun.radiance = 30;
  l.lobes.push_back(sun);
  l.gradient = true;
  l.zenith = 1;
  l.horizon = 0.5;
  l.ground = 0.1;
  return l;
}

const PathEstimator kAll[] = {PathEstimator::Uniform,     PathEstimator::MisTab,      PathEstimator::CdfTab,
                              PathEstimator::MisLightCdf, PathEstimator::MisLightGmm, PathEstimator::MisProduct};

// The sums of a render of a table without color, one per pixel: every pixel's R, G and B
// are required to be equal (a grey table renders grey), and R is returned.
std::vector<double> grey(const std::vector<double>& rgb) {
  REQUIRE(rgb.size() % 3 == 0);
  std::vector<double> out(rgb.size() / 3);
  bool equal = true;
  for (std::size_t i = 0; i < out.size(); ++i) {
    out[i] = rgb[3 * i];
    equal = equal && rgb[3 * i + 1] == out[i] && rgb[3 * i + 2] == out[i];
  }
  REQUIRE(equal);
  return out;
}

double image_mean(const std::vector<double>& sum, int spp) {
  double m = 0;
  for (double v : sum) m += v;
  return m / double(sum.size()) / spp;
}

// The mean of a furnace image's pixels, which all estimate the same value, and its
// standard error from their spread.
std::pair<double, double> pixel_mean_se(const std::vector<double>& sum, int spp) {
  const double mean = image_mean(sum, spp);
  double var = 0;
  for (double v : sum) var += (v / spp - mean) * (v / spp - mean) / double(sum.size() - 1);
  return {mean, std::sqrt(var / double(sum.size()))};
}

// The image mean of `runs` renders of `spp` passes with seeds seed0, seed0 + 1, ..., and
// its standard error from their spread.
std::pair<double, double> mean_over_seeds(const SceneView& view, PathEstimator e, int runs, int spp, std::uint64_t seed0) {
  std::vector<double> per_run;
  for (int r = 0; r < runs; ++r) {
    SceneView v = view;
    v.seed = seed0 + std::uint64_t(r);
    std::vector<double> sum;
    render_passes(v, e, FSource::Table, 0, spp, sum, nullptr);
    per_run.push_back(image_mean(grey(sum), spp));
  }
  double m = 0, var = 0;
  for (double x : per_run) m += x / runs;
  for (double x : per_run) var += (x - m) * (x - m) / (runs - 1);
  return {m, std::sqrt(var / runs)};
}

}  // namespace

TEST_CASE("white furnace: lossless fibers under a constant environment render 1", "[render]") {
  Progress::set_enabled(false);
  const std::string table = small_table("lossless");
  TableBsdf bsdf(table);
  bsdf.set_mixture(fitted_mixture(table));
  // the table's own albedo per theta_o slice (the model's is 1): the furnace's tolerance
  double worst = 0;
  for (std::size_t t = 0; t < bsdf.meta().theta_o.size(); ++t) {
    double a = 0;
    const auto& m = bsdf.meta();
    const double dth = axis_step(m.theta_i), dph = axis_step(m.phi_i);
    for (double th : m.theta_i)
      for (double ph : m.phi_i)
        a += bsdf.f(FSource::Table, m.theta_o[t], th, ph) * (std::sin(th + dth / 2) - std::sin(th - dth / 2)) * dph;
    worst = std::max(worst, std::abs(a - 1));
  }
  std::printf("render_test: furnace: the table's albedo is within %.4f of 1\n", worst);
  REQUIRE(worst < 0.02);
  auto s = make_scene(bsdf, default_lighting(Domain::Hemisphere, 1.0), false, 16);
  const int spp = 256;
  // Uniform sampling is left out of the full furnace: its path weight is a product of
  // f / pdf up to about 60 per bounce over tens of bounces, so heavy-tailed that a finite
  // render's mean sits far below 1 (0.42 +- 0.05 measured). It is checked below on paths
  // of two bounces against cdf_tab, which estimates the same value.
  for (const PathEstimator e : kAll) {
    if (e == PathEstimator::Uniform) continue;
    std::vector<double> sum;
    render_passes(s->view, e, FSource::Table, 0, spp, sum, nullptr);
    const auto [mean, se] = pixel_mean_se(grey(sum), spp);
    std::printf("render_test: furnace %-13s: image mean %.4f +- %.4f\n", path_estimator_name(e), mean, se);
    // the table's albedo error once (its mean over the slices is smaller than the worst
    // slice's), and 0.2% more: a BCSDF 2% short of its energy takes 2% or more at every
    // vertex of a path and fails
    CHECK(std::abs(mean - 1) <= 4 * se + worst + 0.002);
  }
  SceneView v = s->view;
  v.max_depth = 3;
  double m[2], se[2];
  int k = 0;
  for (const PathEstimator e : {PathEstimator::Uniform, PathEstimator::CdfTab}) {
    std::vector<double> sum;
    render_passes(v, e, FSource::Table, 0, 256, sum, nullptr);
    std::tie(m[k], se[k]) = pixel_mean_se(grey(sum), 256);
    ++k;
  }
  std::printf("render_test: furnace, two bounces: uniform %.4f +- %.4f, cdf_tab %.4f +- %.4f\n", m[0], se[0], m[1], se[1]);
  CHECK(std::abs(m[0] - m[1]) <= 4 * std::sqrt(se[0] * se[0] + se[1] * se[1]));
}

TEST_CASE("every path estimator is unbiased: image means over independent seeds agree", "[render]") {
  Progress::set_enabled(false);
  TableBsdf bsdf(small_table("silk"));
  bsdf.set_mixture(broad_mixture(bsdf.meta()));
  auto s = make_scene(bsdf, sky(), true, 8);
  s->view.max_depth = 24;
  const int runs = 24, spp = 8;
  std::vector<double> means, ses;
  for (const PathEstimator e : kAll) {
    const auto [m, se] = mean_over_seeds(s->view, e, runs, spp, 1000);
    means.push_back(m);
    ses.push_back(se);
    std::printf("render_test: unbiased %-13s: image mean %.5f +- %.5f\n", path_estimator_name(e), m, se);
  }
  // against the lowest-noise estimator
  std::size_t best = 0;
  for (std::size_t i = 1; i < means.size(); ++i)
    if (ses[i] < ses[best]) best = i;
  for (std::size_t i = 0; i < means.size(); ++i) {
    const double z = (means[i] - means[best]) / std::sqrt(ses[i] * ses[i] + ses[best] * ses[best] + 1e-30);
    INFO(path_estimator_name(kAll[i]) << " z " << z);
    CHECK(std::abs(z) < 4.5);
  }
}

TEST_CASE("mis_product with a fitted mixture agrees with mis_light_cdf over seeds, with the power to tell", "[render]") {
  Progress::set_enabled(false);
  const std::string table = small_table("silk");
  TableBsdf bsdf(table);
  bsdf.set_mixture(fitted_mixture(table));
  auto s = make_scene(bsdf, sky(), true, 8);
  s->view.max_depth = 24;
  const int runs = 64, spp = 24;
  double m[2], se[2];
  int k = 0;
  for (const PathEstimator e : {PathEstimator::MisLightCdf, PathEstimator::MisProduct}) {
    std::tie(m[k], se[k]) = mean_over_seeds(s->view, e, runs, spp, 2000);
    std::printf("render_test: fitted mixture, %-13s: image mean %.5f +- %.5f\n", path_estimator_name(e), m[k], se[k]);
    ++k;
  }
  // the power to see a bias of a few percent: each standard error under 2 % of the mean
  CHECK(se[1] < 0.02 * m[0]);
  CHECK(std::abs(m[1] - m[0]) < 4.5 * std::sqrt(se[0] * se[0] + se[1] * se[1]));
}

TEST_CASE("the table lookup returns the generator's cells, linear between theta_o slices", "[render]") {
  const std::string path = small_table("cotton");
  TableBsdf bsdf(path);
  const TableMeta& m = bsdf.meta();
  FiberGenerateOptions opt;
  opt.preset = "cotton";
  opt.n_theta_o = 18;
  opt.n_theta_i = 30;
  opt.n_phi_i = 60;
  opt.h_nodes = 64;
  const FiberModel model = fiber_model_for(opt);
  double worst = 0;
  for (std::size_t t : {std::size_t(2), std::size_t(9), std::size_t(15)}) {
    const std::vector<double> ref = tabulate_fiber_slice_cpu(model, m, t, 0);
    const std::vector<double> next = tabulate_fiber_slice_cpu(model, m, t + 1, 0);
    for (std::size_t i = 0; i < m.theta_i.size(); i += 3)
      for (std::size_t j = 0; j < m.phi_i.size(); j += 5) {
        const double a = bsdf.f(FSource::Table, m.theta_o[t], m.theta_i[i], m.phi_i[j]);
        const double r = ref[i * m.phi_i.size() + j];
        worst = std::max(worst, std::abs(a - r) / std::max(r, 1e-30));
        const double mid = bsdf.f(FSource::Table, 0.5 * (m.theta_o[t] + m.theta_o[t + 1]), m.theta_i[i], m.phi_i[j]);
        CHECK(mid == Approx(0.5 * (float(r) + float(next[i * m.phi_i.size() + j]))).epsilon(1e-6));
      }
  }
  std::printf("render_test: table lookup against the generator: worst relative difference %.2e\n", worst);
  CHECK(worst < 1e-6);
}

TEST_CASE("the renderer samples as the study does: the header's sampler and pdf", "[render]") {
  TableBsdf bsdf(small_table("silk"));
  const mix::MixtureSet set = broad_mixture(bsdf.meta());
  bsdf.set_mixture(set);
  for (const double to : {-0.9, -0.2, 0.37, 1.1}) {
    for (int i = 0; i < 500; ++i) {
      double u[4];
      mix::uniforms(7, 11, std::uint64_t(i), u);
      const mix::Sample a = bsdf.mixture_sample(to, u);
      const mix::Sample b = set.sample(to, 0.0, u[0], u[1], u[2], u[3]);
      REQUIRE(a.theta == b.theta);
      REQUIRE(a.phi == b.phi);
      if (a.valid) CHECK(bsdf.mixture_pdf(to, a.theta, a.phi) == set.pdf_omega(to, 0.0, a.theta, a.phi));
    }
  }
  // every sampler's pdf is a density: its integral over the sphere is 1 (mixture: 1 - P(invalid))
  for (const BsdfSampler fs : {BsdfSampler::Uniform, BsdfSampler::TableCdf, BsdfSampler::Mixture}) {
    const int nt = 240, np = 480;
    double mass = 0;
    for (int i = 0; i < nt; ++i)
      for (int j = 0; j < np; ++j) {
        const double th = -kPi / 2 + kPi * (i + 0.5) / nt, ph = -kPi + 2 * kPi * (j + 0.5) / np;
        mass += bsdf.pdf(fs, 0.37, th, ph) * std::cos(th) * (kPi / nt) * (2 * kPi / np);
      }
    // Monte Carlo: the share of samples with a valid direction
    int valid = 0;
    for (int i = 0; i < 20000; ++i) {
      double u[4], th, ph, pdf;
      mix::uniforms(3, 5, std::uint64_t(i), u);
      bsdf.sample(fs, 0.37, u, th, ph, pdf);
      valid += pdf > 0;
    }
    std::printf("render_test: sampler %d: pdf mass %.5f, valid samples %.5f\n", int(fs), mass, valid / 20000.0);
    CHECK(mass == Approx(valid / 20000.0).margin(0.01));
  }
}

TEST_CASE("the stand-in render stays within its integral error of the table render", "[render]") {
  Progress::set_enabled(false);
  // The furnace scene: with the table, every pixel is about 1 (lossless fibers, L = 1).
  // With the fitted mixtures as f, a fiber bounce keeps the stand-in's integral instead
  // of the table's: the render's mean may move by that integral error, compounded over
  // the bounces, and no more. With every scale 10 % too small it must fall measurably.
  const std::string table = small_table("lossless");
  TableBsdf bsdf(table);
  const mix::MixtureSet set = fitted_mixture(table);
  const TableMeta& m = bsdf.meta();
  double err = 0;  // the largest stand-in integral error over the slices (L = 1)
  for (const auto& sl : set.slices) {
    double table_int = 0, mass = 0;
    const double dth = axis_step(m.theta_i), dph = axis_step(m.phi_i);
    for (double th : m.theta_i)
      for (double ph : m.phi_i)
        table_int += bsdf.f(FSource::Table, sl.theta_o, th, ph) * (std::sin(th + dth / 2) - std::sin(th - dth / 2)) * dph;
    for (const auto& g : sl.components) {
      const double sd = std::sqrt(2 * g.s_tt);
      mass += g.weight * 0.5 * (std::erf((kPi / 2 - g.mu_t) / sd) - std::erf((-kPi / 2 - g.mu_t) / sd));
    }
    err = std::max(err, std::abs(sl.scale * mass / table_int - 1));
  }
  auto s = make_scene(bsdf, default_lighting(Domain::Hemisphere, 1.0), false, 10);
  double mean_table = 0;
  for (const double factor : {1.0, 0.9}) {
    mix::MixtureSet scaled = set;
    for (auto& sl : scaled.slices) sl.scale *= factor;
    bsdf.set_mixture(scaled);
    const int runs = 6, spp = 8;
    double d = 0, d2 = 0;
    mean_table = 0;
    for (int r = 0; r < runs; ++r) {
      SceneView v = s->view;
      v.seed = 50 + std::uint64_t(r);
      std::vector<double> a, b;
      render_passes(v, PathEstimator::CdfTab, FSource::Table, 0, spp, a, nullptr);
      render_passes(v, PathEstimator::CdfTab, FSource::StandIn, 0, spp, b, nullptr);
      a = grey(a);
      b = grey(b);
      const double x = image_mean(b, spp) / image_mean(a, spp) - 1;
      d += x / runs;
      d2 += x * x / runs;
      mean_table += image_mean(a, spp) / runs;
    }
    const double se = std::sqrt(std::max(d2 - d * d, 0.0) / (runs - 1));
    std::printf("render_test: stand-in scale x %.1f: image mean %+.4f relative to the table's (+- %.4f; table image "
                "mean %.4f); largest stand-in integral error %.4f\n",
                factor, d, se, mean_table, err);
    if (factor == 1.0) CHECK(std::abs(d) <= 3 * err + 4 * se + 0.005);
    else CHECK(d < -0.05);
  }
}

TEST_CASE("a table whose rgb is its luminance in each channel renders the image of the table without color",
          "[render][color]") {
  Progress::set_enabled(false);
  const double white[3] = {1, 1, 1};
  TableBsdf plain(small_table("silk")), rgb(colored_table("silk", white, "grey"));
  REQUIRE_FALSE(plain.has_rgb());
  REQUIRE(rgb.has_rgb());
  plain.set_mixture(broad_mixture(plain.meta()));
  rgb.set_mixture(broad_mixture(rgb.meta()));
  auto a = make_scene(plain, sky(), true, 10);
  auto b = make_scene(rgb, sky(), true, 10);
  a->view.max_depth = b->view.max_depth = 12;
  for (const PathEstimator e : kAll) {
    std::vector<double> x, y;
    render_passes(a->view, e, FSource::Table, 0, 4, x, nullptr);
    render_passes(b->view, e, FSource::Table, 0, 4, y, nullptr);
    CHECK(x == y);
    grey(y);  // and R = G = B in every pixel
  }
}

TEST_CASE("colored white furnace: one lossless fiber of albedo (1, 1/2, 1/4) under L = 1", "[render][color]") {
  // One straight fiber filling the view: every camera ray meets it once, and no scattered
  // ray can meet it again, so each channel renders its albedo times the table's (about 1;
  // the lossless model's is exactly 1), and G and B are exactly R / 2 and R / 4 (powers of
  // two scale f exactly).
  Progress::set_enabled(false);
  const double color[3] = {1, 0.5, 0.25};
  TableBsdf bsdf(colored_table("lossless", color, "furnace"));
  bsdf.set_mixture(broad_mixture(bsdf.meta()));
  Cloth cloth;
  Fiber f;
  f.radius = 0.5;
  f.points = {{-3, 0, 0}, {-1, 0, 0}, {1, 0, 0}, {3, 0, 0}};
  cloth.fibers = {f};
  cloth.lo = {-3.5, -0.5, -0.5};
  cloth.hi = {3.5, 0.5, 0.5};
  GroundPlane g;
  g.enabled = false;
  const Tracer tracer(cloth, g);
  const Lighting lighting = default_lighting(Domain::Hemisphere, 1.0);
  const LightSampler light = make_light_sampler(lighting);
  SceneView v;
  v.tracer = &tracer;
  v.bsdf = &bsdf;
  v.lighting = &lighting;
  v.light = &light;
  v.camera.position = {0, -1.5, 0.3};
  v.camera.look_at = {0, 0, 0};
  v.camera.fov_deg = 8;
  v.fiber_radius = f.radius;
  v.width = v.height = 12;
  v.max_depth = 8;
  v.threads = 2;
  // the table's albedo: the furnace's tolerance, as in the grey furnace
  double worst = 0;
  const auto& m = bsdf.meta();
  for (std::size_t t = 0; t < m.theta_o.size(); ++t) {
    double a = 0;
    const double dth = axis_step(m.theta_i), dph = axis_step(m.phi_i);
    for (double th : m.theta_i)
      for (double ph : m.phi_i)
        a += bsdf.f(FSource::Table, m.theta_o[t], th, ph) * (std::sin(th + dth / 2) - std::sin(th - dth / 2)) * dph;
    worst = std::max(worst, std::abs(a - 1));
  }
  for (const PathEstimator e : {PathEstimator::CdfTab, PathEstimator::MisLightCdf}) {
    const int spp = 64;
    std::vector<double> sum;
    render_passes(v, e, FSource::Table, 0, spp, sum, nullptr);
    const std::size_t n = sum.size() / 3;
    double mean[3] = {0, 0, 0}, var = 0;
    bool exact = true;
    for (std::size_t p = 0; p < n; ++p) {
      for (int c = 0; c < 3; ++c) mean[c] += sum[3 * p + std::size_t(c)] / spp / double(n);
      exact = exact && sum[3 * p + 1] == 0.5 * sum[3 * p] && sum[3 * p + 2] == 0.25 * sum[3 * p];
    }
    for (std::size_t p = 0; p < n; ++p) var += std::pow(sum[3 * p] / spp - mean[0], 2) / double(n - 1);
    const double se = std::sqrt(var / double(n));
    std::printf("render_test: colored furnace %-13s: R %.4f G %.4f B %.4f (+- %.4f in R; table albedo within %.4f of 1)\n",
                path_estimator_name(e), mean[0], mean[1], mean[2], se, worst);
    CHECK(exact);
    for (int c = 0; c < 3; ++c) CHECK(std::abs(mean[c] / color[c] - 1) <= worst + 4 * se / color[0] + 1e-3);
  }
}

TEST_CASE("surface furnace: a white and a colored Lambertian table on a sphere under L = 1", "[render][color]") {
  // A hemisphere table of f = albedo / pi: its cells integrate f cos exactly to the albedo.
  // The sphere fills the view and is convex, so a camera ray meets it once and leaves to
  // the environment: every pixel renders the albedo, per channel.
  Progress::set_enabled(false);
  const std::string path = (temp_dir() / "lambert_rgb_table.h5").string();
  {
    TableMeta meta = make_grid(Domain::Hemisphere, 8, 1, 16, 32, true);
    meta.rgb = true;
    TableWriter w(path, meta);
    const std::vector<float> v(meta.cells_per_slice(), float(1 / kPi));
    std::vector<float> rgb(3 * v.size());
    for (std::size_t i = 0; i < v.size(); ++i) {
      rgb[3 * i] = v[i];
      rgb[3 * i + 1] = 0.5f * v[i];
      rgb[3 * i + 2] = 0.25f * v[i];
    }
    for (std::size_t t = 0; t < meta.theta_o.size(); ++t) w.write_slice(t, 0, v.data(), rgb.data());
    w.commit();
  }
  TableBsdf bsdf(path);
  const SurfaceMesh sphere = make_sphere({0, 0, 0}, 0.35, 48, 96, "test sphere");
  GroundPlane g;
  g.enabled = false;
  const Tracer tracer(Cloth{}, g, CurveType::FlatLinear, &sphere);
  const Lighting lighting = default_lighting(Domain::Hemisphere, 1.0);
  const LightSampler light = make_light_sampler(lighting);
  SceneView v;
  v.tracer = &tracer;
  v.bsdf = &bsdf;
  v.lighting = &lighting;
  v.light = &light;
  v.camera.position = {0, -1.5, 0.4};
  v.camera.look_at = {0, 0, 0};
  v.camera.fov_deg = 6;
  v.width = v.height = 12;
  v.max_depth = 8;
  v.threads = 2;
  for (const PathEstimator e : {PathEstimator::Uniform, PathEstimator::CdfTab, PathEstimator::MisLightCdf}) {
    const int spp = 64;
    std::vector<double> sum;
    render_passes(v, e, FSource::Table, 0, spp, sum, nullptr);
    const std::size_t n = sum.size() / 3;
    double mean[3] = {0, 0, 0}, var = 0;
    for (std::size_t p = 0; p < n; ++p)
      for (int c = 0; c < 3; ++c) mean[c] += sum[3 * p + std::size_t(c)] / spp / double(n);
    for (std::size_t p = 0; p < n; ++p) var += std::pow(sum[3 * p] / spp - mean[0], 2) / double(n - 1);
    const double se = std::sqrt(var / double(n));
    std::printf("render_test: surface furnace %-13s: R %.4f G %.4f B %.4f (+- %.4f in R)\n", path_estimator_name(e),
                mean[0], mean[1], mean[2], se);
    const double albedo[3] = {1, 0.5, 0.25};
    for (int c = 0; c < 3; ++c) CHECK(std::abs(mean[c] / albedo[c] - 1) <= 4 * se + 2e-3);
  }
}

TEST_CASE("the material mask holds the pixels whose centre sees the sphere", "[render]") {
  // A sphere resting on the ground, seen from above it: the pixels whose centre ray passes
  // the sphere's centre closer than its radius are the material's, the rest the ground's or
  // the sky's. Rays within 2 % of the radius are left out (the mesh is inscribed).
  const double r = 0.35;
  const SurfaceMesh sphere = make_sphere({0, 0, r}, r, 48, 96, "test sphere");
  GroundPlane g;
  g.enabled = true;
  const Tracer tracer(Cloth{}, g, CurveType::FlatLinear, &sphere);
  SceneView v;
  v.tracer = &tracer;
  v.camera.position = {0, -1.5, 0.8};
  v.camera.look_at = {0, 0, r};
  v.camera.fov_deg = 40;
  v.width = 24;
  v.height = 16;
  const std::vector<std::uint8_t> mask = material_mask(v);
  REQUIRE(mask.size() == 24u * 16u);
  int material = 0, checked = 0, ground = 0;
  for (int y = 0; y < v.height; ++y)
    for (int x = 0; x < v.width; ++x) {
      const Ray ray = camera_ray(v.camera, v.width, v.height, x + 0.5, y + 0.5);
      const Vec3 to{-ray.org[0], -ray.org[1], r - ray.org[2]};
      const double t = dot(to, ray.dir);
      const double d = std::sqrt(std::max(0.0, dot(to, to) - t * t));  // ray to the centre
      if (std::abs(d - r) < 0.02 * r) continue;
      ++checked;
      const bool inside = d < r;
      CHECK(bool(mask[std::size_t(y * v.width + x)]) == inside);
      material += inside;
      ground += !inside && ray.dir[2] < 0;
    }
  CHECK(checked > 300);
  CHECK(material > 40);  // both kinds of pixel are there
  CHECK(ground > 40);
}

TEST_CASE("a render is reproducible for a seed, whatever the thread count", "[render]") {
  Progress::set_enabled(false);
  TableBsdf bsdf(small_table("silk"));
  bsdf.set_mixture(broad_mixture(bsdf.meta()));
  auto s = make_scene(bsdf, sky(), true, 10);
  s->view.max_depth = 12;
  for (const PathEstimator e : kAll) {
    std::vector<double> a, b, c;
    SceneView v = s->view;
    v.threads = 1;
    render_passes(v, e, FSource::Table, 0, 3, a, nullptr);
    v.threads = 3;
    render_passes(v, e, FSource::Table, 0, 3, b, nullptr);
    v.seed = 2;
    render_passes(v, e, FSource::Table, 0, 3, c, nullptr);
    CHECK(a == b);
    CHECK(a != c);
  }
}

namespace {

// What the guided tests learn with: small leaves, K <= 4, two iterations (passes 1, then
// 2 and 3), the first two vertices of a path guided, half of their directions by the
// guide wherever a leaf has a mixture.
GuideSetup small_guide() {
  GuideSetup g;
  g.field.leaf_samples = 400;
  g.field.min_vertices = 40;
  g.field.grid_theta = 8;
  g.field.grid_phi = 16;
  g.field.fit.k_max = 4;
  g.field.fit.restarts = g.field.fit.final_restarts = 1;
  g.field.fit.iterations = 30;
  g.field.fit.final_iterations = 60;
  g.field.fit.refine = "none";
  g.field.adapt_share = false;  // every leaf guides half the directions: the guided sampling is exercised
  g.iterations = 2;
  g.depth = 2;
  g.devices = select_devices("");
  return g;
}

// A guided render of `spp` passes that learns in its first ones, as the comparisons do;
// `fitted` receives the leaves with a mixture at the end.
std::vector<double> guided_render(const SceneView& view, PathEstimator e, const GuideSetup& g, int spp,
                                  std::size_t* fitted = nullptr) {
  GuideTrainer t(view, g, "render_test");
  std::vector<double> sum;
  render_passes(t.view(), e, FSource::Table, 0, spp, sum, [&](int done, double) {
    t.after_pass(done);
    return true;
  });
  if (fitted) *fitted = t.field().fitted();
  return sum;
}

}  // namespace

TEST_CASE("the guided estimators are unbiased: image means over seeds agree with mis_light_cdf's", "[render][guide]") {
  Progress::set_enabled(false);
  const std::string table = small_table("silk");
  TableBsdf bsdf(table);
  bsdf.set_mixture(fitted_mixture(table));
  auto s = make_scene(bsdf, sky(), true, 12);
  s->view.max_depth = 24;
  const GuideSetup g = small_guide();
  const int runs = 40, spp = 8;
  const auto [m0, se0] = mean_over_seeds(s->view, PathEstimator::MisLightCdf, runs, spp, 2000);
  for (const PathEstimator e : {PathEstimator::Guided, PathEstimator::GuidedProduct}) {
    std::vector<double> per_run;
    std::size_t fitted = 0;
    for (int r = 0; r < runs; ++r) {
      SceneView v = s->view;
      v.seed = 2000 + std::uint64_t(r);
      std::size_t f = 0;
      per_run.push_back(image_mean(grey(guided_render(v, e, g, spp, &f)), spp));
      fitted += f;
    }
    double m = 0, var = 0;
    for (double x : per_run) m += x / runs;
    for (double x : per_run) var += (x - m) * (x - m) / (runs - 1);
    const double se = std::sqrt(var / runs), z = (m - m0) / std::sqrt(se * se + se0 * se0);
    std::printf("render_test: unbiased %-14s: image mean %.5f +- %.5f (mis_light_cdf %.5f +- %.5f), %zu leaves fitted\n",
                path_estimator_name(e), m, se, m0, se0, fitted);
    CHECK(fitted > 0);  // the guide was learnt and sampled
    CHECK(std::abs(z) < 4.5);
  }
}

TEST_CASE("guided white furnace: lossless fibers under a constant environment render 1", "[render][guide]") {
  Progress::set_enabled(false);
  const std::string table = small_table("lossless");
  TableBsdf bsdf(table);
  bsdf.set_mixture(fitted_mixture(table));
  auto s = make_scene(bsdf, default_lighting(Domain::Hemisphere, 1.0), false, 16);
  const int spp = 256;
  for (const PathEstimator e : {PathEstimator::Guided, PathEstimator::GuidedProduct}) {
    std::size_t fitted = 0;
    const auto [mean, se] = pixel_mean_se(grey(guided_render(s->view, e, small_guide(), spp, &fitted)), spp);
    std::printf("render_test: furnace %-14s: image mean %.4f +- %.4f, %zu leaves fitted\n", path_estimator_name(e), mean,
                se, fitted);
    CHECK(fitted > 0);
    // the noise and the table's albedo error (within 0.6% on every slice, the furnace above)
    CHECK(std::abs(mean - 1) <= 4 * se + 0.006);
  }
}

TEST_CASE("a guided render is reproducible for a seed, whatever the thread count", "[render][guide]") {
  Progress::set_enabled(false);
  TableBsdf bsdf(small_table("silk"));
  bsdf.set_mixture(broad_mixture(bsdf.meta()));
  auto s = make_scene(bsdf, sky(), true, 12);
  s->view.max_depth = 12;
  const GuideSetup g = small_guide();
  for (const PathEstimator e : {PathEstimator::Guided, PathEstimator::GuidedProduct}) {
    SceneView v = s->view;
    v.threads = 1;
    const std::vector<double> a = guided_render(v, e, g, 4);
    v.threads = 3;
    const std::vector<double> b = guided_render(v, e, g, 4);
    v.seed = 2;
    const std::vector<double> c = guided_render(v, e, g, 4);
    CHECK(a == b);
    CHECK(a != c);
  }
}

TEST_CASE("the default estimators leave out the experimental guided ones, which stay selectable by name",
          "[render][guide]") {
  const std::string table = small_table("silk");
  using E = PathEstimator;
  const Config plain = parse_config("table: " + table + "\nrender:\n  seed: 1\n", "plain.yaml");
  const RenderSettings d = parse_render(*plain.render);
  CHECK(d.estimators == std::vector<E>{E::Uniform, E::MisTab, E::CdfTab, E::MisLightCdf, E::MisLightGmm, E::MisProduct});
  CHECK(d.summary_figure == "figures/summary.png");
  const Config named =
      parse_config("table: " + table + "\nrender:\n  estimators: [mis_light_cdf, guided, guided_product]\n", "named.yaml");
  CHECK(parse_render(*named.render).estimators == std::vector<E>{E::MisLightCdf, E::Guided, E::GuidedProduct});
}

TEST_CASE("bad render configs are rejected with one line naming the key", "[render]") {
  const std::string table = small_table("silk");
  auto error = [&](const std::string& body) {
    try {
      const Config c = parse_config("table: " + table + "\nrender:\n" + body, "scene.yaml");
      parse_render(*c.render);
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  CHECK_THAT(error("  estimators: [uniform, mis_tabb]\n"), Catch::Contains("scene.yaml: render.estimators (line 3)") &&
                                                              Catch::Contains("unknown estimator 'mis_tabb'"));
  CHECK_THAT(error("  camera: {position: [0, 1]}\n"), Catch::Contains("render.camera.position") &&
                                                         Catch::Contains("three numbers"));
  CHECK_THAT(error("  cloth: {weav: plain}\n"), Catch::Contains("render.cloth.weav") && Catch::Contains("unknown key"));
  CHECK_THAT(error("  scene: nowhere.yaml\n"), Catch::Contains("render.scene") && Catch::Contains("nowhere.yaml: no such file"));
  CHECK_THAT(error("  width: 0\n"), Catch::Contains("render.width (line 3)"));
  CHECK_THAT(error("  ground: {albedo: 2}\n"), Catch::Contains("render.ground.albedo"));
  CHECK_THAT(error("  product_share: 1\n"), Catch::Contains("render.product_share (line 3)") &&
                                                Catch::Contains("strictly between 0 and 1"));
  CHECK_THAT(error("  guide: {share: 1}\n"), Catch::Contains("render.guide.share") && Catch::Contains("strictly between"));
  CHECK_THAT(error("  guide: {grid: [1, 32]}\n"), Catch::Contains("render.guide.grid") && Catch::Contains("integers"));
  CHECK_THAT(error("  guide: {depth: 0}\n"), Catch::Contains("render.guide.depth"));
  CHECK_THAT(error("  guide: {sharee: 0.5}\n"), Catch::Contains("render.guide.sharee") && Catch::Contains("unknown key"));
  CHECK_THAT(error("  reference_estimator: guided\n"), Catch::Contains("render.reference_estimator") &&
                                                          Catch::Contains("learns within each render"));
  CHECK_THAT(error("  cloth: {weave: satin}\n"),
             Catch::Contains("no error"));  // parsed here; make_cloth rejects it, below
  ClothParams p;
  p.weave = "satin";
  CHECK_THROWS_WITH(make_cloth(p, "scene.yaml: render.cloth"), Catch::Contains("weave"));
}

TEST_CASE("a measured channel's cells below zero reflect nothing", "[render][color]") {
  // cg_sunflower's blue is noise around zero; rendered as it is, its negative cells
  // made negative pixels, which no image may hold.
  const std::string path = (temp_dir() / "negative_rgb_table.h5").string();
  TableMeta meta = make_grid(Domain::Hemisphere, 4, 1, 8, 16, true);
  meta.rgb = true;
  {
    TableWriter w(path, meta);
    const std::vector<float> v(meta.cells_per_slice(), 0.2f);
    std::vector<float> rgb(3 * v.size());
    for (std::size_t i = 0; i < v.size(); ++i) {
      rgb[3 * i] = 0.3f;
      rgb[3 * i + 1] = 0.2f;
      rgb[3 * i + 2] = i % 2 ? 0.01f : -0.01f;
    }
    for (std::size_t t = 0; t < meta.theta_o.size(); ++t) w.write_slice(t, 0, v.data(), rgb.data());
    w.commit();
  }
  TableBsdf bsdf(path);
  std::size_t zero = 0, positive = 0;
  for (double th : meta.theta_i)
    for (double ph : meta.phi_i) {
      const Rgb c = bsdf.f_rgb(FSource::Table, meta.theta_o[1], th, ph);
      CHECK(c[2] >= 0);
      CHECK(c[0] == Approx(0.3));
      zero += c[2] == 0;
      positive += c[2] > 0;
    }
  CHECK(zero == meta.cells_per_slice() / 2);  // the negative half, read as 0
  CHECK(positive == meta.cells_per_slice() / 2);
}

namespace {

// satin_rosaline (data/rgl/) imported on a small grid (8 theta_o x 30 x 60 cells), kept in
// the temp directory, and the file itself.
std::string small_rgl_table(const std::string& rgl) {
  const std::string path = (temp_dir() / "satin_rgl_small_table.h5").string();
  if (!fs::exists(path)) {
    RglImportOptions opt;
    opt.file = rgl;
    opt.n_theta_o = 8;
    opt.n_theta_i = 30;
    opt.n_phi_i = 60;
    opt.threads = 2;
    import_rgl_table(opt, path);
  }
  return path;
}

const std::string kSatin = std::string(BSDFMIX_SOURCE_DIR) + "/data/rgl/satin_rosaline_rgb.bsdf";

}  // namespace

TEST_CASE("the RGL sampler of a measured surface: its pdf is the warps' density where it samples", "[render][rgl]") {
  const RglBrdf rgl(kSatin);
  TableBsdf bsdf(small_rgl_table(kSatin));
  bsdf.set_rgl(&rgl);
  std::size_t valid = 0;
  double worst = 0;
  for (std::uint32_t i = 0; i < 4000; ++i) {
    double u[4];
    mix::uniforms(77, 1, i, u);
    const double theta_o = 1.45 * u[0] + 0.02;
    double th = 0, ph = 0, pdf = 0;
    mix::uniforms(77, 2, i, u);
    bsdf.sample(BsdfSampler::Rgl, theta_o, u, th, ph, pdf);
    if (!(pdf > 0)) continue;
    ++valid;
    CHECK(th >= 0);
    CHECK(th <= kPi / 2);
    worst = std::max(worst, std::abs(bsdf.pdf(BsdfSampler::Rgl, theta_o, th, ph) / pdf - 1));
  }
  std::printf("render_test: RGL sampler: %zu of 4000 samples valid, pdf() within %.2g of the sampler's density\n", valid,
              worst);
  CHECK(valid > 3600);
  CHECK(worst < 1e-6);
  // a fiber table has no RGL file
  TableBsdf fiber(small_table("silk"));
  CHECK_THROWS_WITH(fiber.set_rgl(&rgl), Catch::Contains("measured surface"));
}

TEST_CASE("is_rgl and mis_light_rgl on a measured sphere agree with mis_light_cdf over seeds", "[render][rgl]") {
  // f is the table's for every estimator: only the sampler differs, so the image means agree.
  Progress::set_enabled(false);
  const RglBrdf rgl(kSatin);
  TableBsdf bsdf(small_rgl_table(kSatin));
  bsdf.set_rgl(&rgl);
  const SurfaceMesh sphere = make_sphere({0, 0, 0.29}, 0.35, 32, 64, "test sphere");
  GroundPlane g;
  g.enabled = true;
  g.z = -0.06;
  g.half = 4;
  const Tracer tracer(Cloth{}, g, CurveType::FlatLinear, &sphere);
  const Lighting lighting = sky();
  const LightSampler light = make_light_sampler(lighting);
  SceneView v;
  v.tracer = &tracer;
  v.bsdf = &bsdf;
  v.lighting = &lighting;
  v.light = &light;
  v.camera.position = {0, -1.2, 0.75};
  v.camera.look_at = {0, 0, 0.22};
  v.camera.fov_deg = 36;
  v.width = v.height = 8;
  v.max_depth = 12;
  v.threads = 2;
  const int runs = 32, spp = 16;
  const auto [m0, se0] = [&] {
    std::vector<double> per_run;
    for (int r = 0; r < runs; ++r) {
      SceneView w = v;
      w.seed = 3000 + std::uint64_t(r);
      std::vector<double> sum;
      render_passes(w, PathEstimator::MisLightCdf, FSource::Table, 0, spp, sum, nullptr);
      per_run.push_back(image_mean(sum, spp));
    }
    double m = 0, var = 0;
    for (double x : per_run) m += x / runs;
    for (double x : per_run) var += (x - m) * (x - m) / (runs - 1);
    return std::pair<double, double>{m, std::sqrt(var / runs)};
  }();
  for (const PathEstimator e : {PathEstimator::IsRgl, PathEstimator::MisLightRgl}) {
    std::vector<double> per_run;
    for (int r = 0; r < runs; ++r) {
      SceneView w = v;
      w.seed = 3000 + std::uint64_t(r);
      std::vector<double> sum;
      render_passes(w, e, FSource::Table, 0, spp, sum, nullptr);
      per_run.push_back(image_mean(sum, spp));
    }
    double m = 0, var = 0;
    for (double x : per_run) m += x / runs;
    for (double x : per_run) var += (x - m) * (x - m) / (runs - 1);
    const double se = std::sqrt(var / runs), z = (m - m0) / std::sqrt(se * se + se0 * se0);
    std::printf("render_test: measured sphere %-13s: image mean %.5f +- %.5f (mis_light_cdf %.5f +- %.5f), z %.2f\n",
                path_estimator_name(e), m, se, m0, se0, z);
    CHECK(se < 0.03 * m0);  // the power to see a bias of a few percent
    CHECK(std::abs(z) < 4.5);
  }
}

TEST_CASE("is_rgl and mis_light_rgl are refused, in one line, where the table is not imported from an RGL file",
          "[render][rgl]") {
  const std::string table = small_table("silk");
  const Config c = parse_config("table: " + table + "\nfit:\n  k_max: 4\nrender:\n  estimators: [mis_light_cdf, is_rgl]\n",
                                "cloth.yaml");
  CHECK(parse_render(*c.render).estimators == std::vector<PathEstimator>{PathEstimator::MisLightCdf, PathEstimator::IsRgl});
  try {
    render_settings(c);
    FAIL("no error");
  } catch (const ConfigError& e) {
    const std::string m = e.what();
    CHECK_THAT(m, Catch::Contains("cloth.yaml: render: estimator 'is_rgl'") && Catch::Contains("import.rgl"));
    CHECK(m.find('\n') == std::string::npos);
  }
  const Config named = parse_config("table: " + table + "\nrender:\n  estimators: [mis_light_rgl, is_rgl]\n", "n.yaml");
  CHECK(parse_render(*named.render).estimators ==
        std::vector<PathEstimator>{PathEstimator::MisLightRgl, PathEstimator::IsRgl});
}
