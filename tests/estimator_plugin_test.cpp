// An estimator defined in this file alone and registered with one call
// (sampling/estimator.hpp, register_estimator) serves both the convergence study (its CPU
// path: no kernel implements it) and the renderer (its own draw at a material vertex,
// joined by light samples): it converges to the table's integral as cdf_tab does, and its
// renders of a measured sphere under a sky agree with mis_light_cdf's over seeds.
// labels: render converge sample
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdio>
#include <filesystem>

#include "config/config.hpp"
#include "converge/study.hpp"
#include "core/progress.hpp"
#include "io/mixture_file.hpp"
#include "io/table.hpp"
#include "render/integrator.hpp"
#include "render/render_settings.hpp"
#include "render/surface.hpp"
#include "sampling/sampling.hpp"

using namespace bsdfmix;
namespace fs = std::filesystem;

namespace {

// ---- the estimator: half uniform, half the table's CDF, one-sample MIS (balance) --------

double cos_factor(const Problem& p, double th) { return p.table.domain == Domain::Hemisphere ? std::cos(th) : 1.0; }

double half_pdf(const Problem& p, double th, double ph) {
  return 0.5 * estimator_pdf(p, Estimator::UsTab, th, ph) + 0.5 * estimator_pdf(p, Estimator::CdfTab, th, ph);
}

bool half_draw(const Problem& p, const double u[4], double& th, double& ph) {
  const double v[4] = {u[0] < 0.5 ? 2 * u[0] : 2 * u[0] - 1, u[1], u[2], u[3]};
  return draw_cpu(p, u[0] < 0.5 ? Estimator::UsTab : Estimator::CdfTab, v, th, ph);
}

double half_estimate(const Problem& p, const double u[4]) {
  double th, ph;
  if (!half_draw(p, u, th, ph)) return 0;
  const double pdf = half_pdf(p, th, ph);
  return pdf > 0 ? p.light.radiance(th, ph) * p.table.f_at(th, ph) * cos_factor(p, th) / pdf : 0.0;
}

// The same draw at a path's material vertex, with the material's two techniques.
class HalfSampler : public VertexSampler {
 public:
  void sample(const render::TableBsdf& m, double theta_o, const double u[4], double& th, double& ph,
              double& pdf) const override {
    const double v[4] = {u[0] < 0.5 ? 2 * u[0] : 2 * u[0] - 1, u[1], u[2], u[3]};
    m.sample(u[0] < 0.5 ? BsdfSampler::Uniform : BsdfSampler::TableCdf, theta_o, v, th, ph, pdf);
    if (pdf > 0) pdf = this->pdf(m, theta_o, th, ph);
  }
  double pdf(const render::TableBsdf& m, double theta_o, double th, double ph) const override {
    return 0.5 * m.pdf(BsdfSampler::Uniform, theta_o, th, ph) + 0.5 * m.pdf(BsdfSampler::TableCdf, theta_o, th, ph);
  }
};
const HalfSampler kHalfSampler;

const Estimator kHalf = [] {
  EstimatorInfo e;
  e.name = "half_cdf";
  e.draws = "uniform + table CDF";
  e.study = {half_estimate, half_pdf, half_draw};
  e.render.renders = true;
  e.render.sampler = &kHalfSampler;
  e.render.light_sampling = true;
  return register_estimator(e);
}();

// ---- a measured material: a hemisphere table with a glossy lobe, and a mixture for it ----

fs::path temp_dir() {
  const fs::path d = fs::temp_directory_path() / "bsdfmix_estimator_plugin_test";
  fs::create_directories(d);
  return d;
}

struct Material {
  std::string table, mixture;
};

const Material& glossy() {
  static const Material m = [] {
    Material out{(temp_dir() / "glossy.h5").string(), (temp_dir() / "glossy_mixture.h5").string()};
    const TableMeta meta = make_grid(Domain::Hemisphere, 4, 1, 24, 48, true);
    std::vector<float> values;
    MixtureFile mf;
    mf.domain = Domain::Hemisphere;
    mf.azimuthal = true;
    mf.table_theta_o = meta.theta_o;
    mf.table_phi_o = meta.phi_o;
    for (const double to : meta.theta_o) {
      for (const double th : meta.theta_i)
        for (const double ph : meta.phi_i) {
          const double dt = th - to, dp = wrap_phi(ph - kPi);
          values.push_back(float((0.25 + 2.0 * std::exp(-0.5 * (dt * dt + dp * dp) / 0.09)) / kPi));
        }
      mf.add_slice(to, 0.0, 1.0, 0.0, 0.05, {0.7, 0.3}, {to, 3.0, 0.7, 0.0}, {0.1, 0.0, 0.1, 0.5, 0.0, 4.0});
    }
    write_table(out.table, meta, values);
    write_mixture_file(out.mixture, mf);
    return out;
  }();
  return m;
}

Lighting sky() {
  Lighting l = default_lighting(Domain::Hemisphere, 0.2);
  l.name = "sky";
  LightLobe sun;
  sun.direction = {0.3, -0.5, std::sqrt(1 - 0.34)};
  sun.kappa = std::log(2.0) / (1 - std::cos(10 * kPi / 180));
  sun.radiance = 10;
  l.lobes.push_back(sun);
  return l;
}

}  // namespace

TEST_CASE("a registered estimator is one list entry, named in both the study's and the renderer's lists", "[plugin]") {
  const EstimatorInfo& e = estimator_info(kHalf);
  CHECK(e.name == "half_cdf");
  CHECK(find_estimator("half_cdf") == &e);
  CHECK_FALSE(on_device(kHalf));
  CHECK(parse_estimator("half_cdf", "x") == kHalf);
  CHECK(estimator_list().find("half_cdf") != std::string::npos);
  CHECK(render::path_strategy(kHalf).sampler == &kHalfSampler);
  CHECK_THROWS(register_estimator(e));  // its name is taken
  // the configs name it as they name the built-in ones
  const Config c = parse_config("table: " + glossy().table + "\nrender:\n  estimators: [half_cdf, mis_light_cdf]\n",
                                "plugin.yaml");
  CHECK(render::parse_render(*c.render).estimators == std::vector<Estimator>{kHalf, Estimator::MisLightCdf});
  CHECK(path_estimator_list().find("half_cdf") != std::string::npos);
}

TEST_CASE("the convergence study runs a registered estimator on its CPU path: it converges as cdf_tab does",
          "[plugin][converge]") {
  Progress::set_enabled(false);
  StudySpec spec;
  spec.table = glossy().table;
  spec.mixture = glossy().mixture;
  spec.table_label = "glossy";
  spec.directions = {{0.5, 0.0}};
  spec.scenes = {sky()};
  spec.estimators = {Estimator::CdfTab, kHalf};
  spec.runs = 32;
  spec.samples_max = 4096;
  spec.cpu = true;
  spec.timing_rounds = 0;
  spec.csv = (temp_dir() / "conv.csv").string();
  spec.tail_csv = (temp_dir() / "conv_tail.csv").string();
  const std::vector<ConvergenceRow> rows = run_study(spec);
  const ConvergenceRow *cdf = nullptr, *half = nullptr;
  for (const ConvergenceRow& r : rows)
    if (r.samples == spec.samples_max) (r.estimator == "cdf_tab" ? cdf : half) = &r;
  REQUIRE(cdf != nullptr);
  REQUIRE(half != nullptr);
  CHECK(half->estimator == "half_cdf");
  const double se_half = half->rmse / std::sqrt(double(spec.runs)), se_cdf = cdf->rmse / std::sqrt(double(spec.runs));
  std::printf("estimator_plugin_test: study: half_cdf %.6f +- %.6f, cdf_tab %.6f +- %.6f, reference %.6f\n", half->mean,
              se_half, cdf->mean, se_cdf, half->reference);
  REQUIRE(half->rmse > 0);
  CHECK(std::abs(half->mean - half->reference) <= 4 * se_half);
  CHECK(std::abs(half->mean - cdf->mean) <= 4 * std::hypot(se_half, se_cdf));
  // its error falls as 1 / sqrt(N)
  const ConvergenceRow* early = nullptr;
  for (const ConvergenceRow& r : rows)
    if (r.estimator == "half_cdf" && r.samples == 64) early = &r;
  REQUIRE(early != nullptr);
  CHECK(half->rmse < early->rmse / 4);
}

TEST_CASE("the renderer draws with a registered estimator: a measured sphere renders as with mis_light_cdf",
          "[plugin][render]") {
  Progress::set_enabled(false);
  render::TableBsdf bsdf(glossy().table);
  const render::SurfaceMesh sphere = render::make_sphere({0, 0, 0}, 0.35, 48, 96, "test sphere");
  render::GroundPlane g;
  g.enabled = false;
  const render::Tracer tracer(render::Cloth{}, g, render::CurveType::FlatLinear, &sphere);
  const Lighting lighting = sky();
  const LightSampler light = make_light_sampler(lighting);
  render::SceneView v;
  v.tracer = &tracer;
  v.bsdf = &bsdf;
  v.lighting = &lighting;
  v.light = &light;
  v.camera.position = {0, -1.5, 0.4};
  v.camera.look_at = {0, 0, 0};
  v.camera.fov_deg = 20;
  v.width = v.height = 12;
  v.max_depth = 8;
  v.threads = 2;
  const int runs = 8, spp = 16;
  auto mean_over_seeds = [&](Estimator e, std::uint64_t seed0) {
    std::vector<double> means;
    for (int r = 0; r < runs; ++r) {
      render::SceneView w = v;
      w.seed = seed0 + std::uint64_t(r);
      std::vector<double> sum;
      render::render_passes(w, e, render::FSource::Table, 0, spp, sum, nullptr);
      double m = 0;
      for (const double x : sum) m += x / double(sum.size()) / spp;
      means.push_back(m);
    }
    double m = 0, var = 0;
    for (const double x : means) m += x / runs;
    for (const double x : means) var += (x - m) * (x - m) / (runs - 1);
    return std::pair<double, double>{m, std::sqrt(var / runs)};
  };
  const auto [m_half, se_half] = mean_over_seeds(kHalf, 100);
  const auto [m_ref, se_ref] = mean_over_seeds(Estimator::MisLightCdf, 200);
  const double z = (m_half - m_ref) / std::hypot(se_half, se_ref);
  std::printf("estimator_plugin_test: render: half_cdf %.5f +- %.5f, mis_light_cdf %.5f +- %.5f, z %.2f\n", m_half,
              se_half, m_ref, se_ref, z);
  REQUIRE(m_ref > 0);
  CHECK(std::abs(z) < 4);
  CHECK(se_half < 0.05 * m_ref);  // the comparison has the power to tell a bias of a few percent
}
