// The estimators of kernels/sample.cl (integrate_chunks) and their CPU reference
// (host/sampling/sample_reference.cpp), the quadrature references and the convergence
// study (host/converge): every table estimator unbiased, is_gmm converging to the
// stand-in's integral (its bias is the stand-in's integral error), device and CPU
// agreeing, scenes (lobes, gradient, PFM environment map, frames, errors), the exact
// CSV columns of `bsdfmix converge`, and is_rgl and mis_light_rgl (an RGL file's own
// warps, on the CPU) unbiased on a table imported from that file.
// labels: sample
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <sstream>

#include "scene/light_mixture.hpp"
#include "converge/quadrature.hpp"
#include "scene/scene.hpp"
#include "converge/study.hpp"
#include "core/error.hpp"
#include "core/progress.hpp"
#include "io/mixture_file.hpp"
#include "io/pfm.hpp"
#include "io/table.hpp"
#include "sampling/sampling.hpp"
#include "sweep/earned_share.hpp"
#include "sweep/map_choice.hpp"
#include "tables/rgl_brdf.hpp"
#include "tables/rgl_import.hpp"

using namespace bsdfmix;
namespace fs = std::filesystem;

namespace {

constexpr std::uint64_t kSeed = 97;

fs::path temp_dir() {
  const fs::path d = fs::temp_directory_path() / "bsdfmix_converge_test";
  fs::create_directories(d);
  return d;
}

double lobe(double dt, double dp, double st, double sp) {
  double s = 0;
  for (int m = -1; m <= 1; ++m) {
    const double p = dp + 2 * kPi * m;
    s += std::exp(-0.5 * (dt * dt / (st * st) + p * p / (sp * sp)));
  }
  return s;
}

// A small table (3 theta_o slices, 24 x 48 cells) whose f is a lobe that moves with
// theta_o plus a floor, and a mixture file for it: the lobe's Gaussian and a broad
// Gaussian (which keeps the mixture positive wherever f is), scale = the integral, and
// the uniform share each slice earns (sweep/earned_share.hpp).
struct Fixture {
  std::string table, mixture;
  Domain domain;
};

Fixture make_fixture(Domain domain) {
  const std::string tag = domain == Domain::Fiber ? "fiber" : "hemi";
  Fixture fx{(temp_dir() / (tag + "_table.h5")).string(), (temp_dir() / (tag + "_mixture.h5")).string(), domain};
  TableMeta meta = make_grid(domain, 3, 1, 24, 48, true);
  meta.source = "{\"model\": \"test\"}";
  const std::size_t nt = meta.theta_i.size(), np = meta.phi_i.size();
  std::vector<float> values;
  MixtureFile m;
  m.domain = domain;
  m.azimuthal = true;
  m.table_theta_o = meta.theta_o;
  m.table_phi_o = meta.phi_o;
  for (std::size_t s = 0; s < meta.theta_o.size(); ++s) {
    const double to = meta.theta_o[s];
    const double mt = domain == Domain::Fiber ? -0.5 * to : 0.3 + 0.3 * s;
    const double mp = 2.6 - 0.4 * double(s);  // near phi = pi for s = 0
    std::vector<double> f(nt * np);
    std::vector<double> w = integrand_weights(domain, meta.theta_i, meta.phi_i,
                                              std::vector<float>(nt * np, 1.0f).data());  // cell weights with f = 1
    double integral = 0;
    for (std::size_t i = 0; i < nt; ++i)
      for (std::size_t j = 0; j < np; ++j) {
        const double th = meta.theta_i[i];
        const double c = domain == Domain::Hemisphere ? std::cos(th) : 1.0;
        f[i * np + j] = (0.02 + 3.0 * lobe(th - mt, wrap_phi(meta.phi_i[j] - mp), 0.2, 0.35) / (c * jacobian(domain, th)));
        integral += f[i * np + j] * w[i * np + j];
        values.push_back(float(f[i * np + j]));
      }
    m.add_slice(to, 0.0, integral, 0.0, 0.05, {0.85, 0.15}, {mt, mp, 0.1, 0.0},
                {0.2 * 0.2, 0.0, 0.35 * 0.35, 0.7 * 0.7, 0.0, 2.0 * 2.0});
    WeightedSlice ws{meta.theta_i, meta.phi_i, w, mix::Map::ThetaPhi};
    for (std::size_t c = 0; c < ws.w.size(); ++c) ws.w[c] *= f[c];
    m.defensive.back() = earned_share(ws, slice_mixture(m, s), domain).share;
  }
  write_table(fx.table, meta, values);
  write_mixture_file(fx.mixture, m);
  return fx;
}

const Fixture& fiber() {
  static Fixture f = make_fixture(Domain::Fiber);
  return f;
}
const Fixture& hemisphere() {
  static Fixture f = make_fixture(Domain::Hemisphere);
  return f;
}

const Device& device() {
  static std::vector<Device> d = select_devices("");
  return d.front();
}

Lighting sky(Domain d) {
  Lighting l = default_lighting(d, 0.2);
  l.name = "sky";
  LightLobe sun;
  sun.direction = {0.3, 0.5, std::sqrt(1 - 0.34)};
  sun.kappa = std::log(2.0) / (1 - std::cos(8 * kPi / 180));
  sun.radiance = 20;
  l.lobes.push_back(sun);
  l.gradient = true;
  l.zenith = 1.0;
  l.horizon = 0.4;
  l.ground = 0.1;
  return l;
}

// A small lat-long map (32 x 16) with a bright 2-pixel "sun" over a smooth sky.
Lighting map(Domain d) {
  Lighting l = default_lighting(d, 0.0);
  l.name = "map";
  l.env_width = 32;
  l.env_height = 16;
  l.env_scale = 1.0;
  l.env.assign(32 * 16, 0.f);
  for (int y = 0; y < 16; ++y)
    for (int x = 0; x < 32; ++x)
      l.env[std::size_t(y * 32 + x)] = float(0.3 + 0.5 * std::cos(kPi * (y + 0.5) / 16) * (y < 8) + 0.1 * std::sin(x * 0.4));
  l.env[std::size_t(4 * 32 + 20)] = 400.f;
  l.env[std::size_t(4 * 32 + 21)] = 200.f;
  return l;
}

// The lighting's mixture on the table's grid, fitted by the sweep (cached in the temp dir).
mix::SliceMixture light_mixture(const Fixture& fx, const Lighting& light) {
  Progress::set_enabled(false);
  const TableReader table(fx.table);
  FitSettings fit;
  fit.k_min = 1;
  fit.k_max = 8;
  fit.restarts = 1;
  fit.final_restarts = 1;
  fit.final_iterations = 100;
  fit.map = "theta_phi";  // the fixture's mixtures are in (theta, phi): the product needs one plane
  Lighting l = light;
  l.domain = fx.domain;
  return lighting_mixture(l, table.meta(), fit, (temp_dir() / "light_cache").string(), "").mixture;
}

struct Stats {
  double mean = 0, sd = 0;  // of the per-run estimates at N_max
};

Stats stats(const RunSums& s) {
  Stats st;
  const double N = std::ldexp(1.0, s.levels - 1);
  for (int r = 0; r < s.runs; ++r) st.mean += s.at(r, s.levels - 1) / N;
  st.mean /= s.runs;
  for (int r = 0; r < s.runs; ++r) {
    const double e = s.at(r, s.levels - 1) / N - st.mean;
    st.sd += e * e;
  }
  st.sd = std::sqrt(st.sd / (s.runs - 1));
  return st;
}

void check_unbiased(const Fixture& fx, const Lighting& light, double to, double po, bool power = false) {
  Progress::set_enabled(false);
  const TableReader table(fx.table);
  const mix::MixtureSet set = to_mixture_set(read_mixture_file(fx.mixture));
  const mix::SliceMixture lm = light_mixture(fx, light);
  MisOptions mis;
  mis.power = power;
  mis.earned = true;  // mis_tab and mis_light_gmm with each slice's earned share
  const Problem p = make_problem(table, set, to, po, light, mis, &lm);
  CHECK(p.mis.uniform_fraction == set.defensive(to, po));
  std::printf("converge_test: earned uniform share at theta_o %.3f: %.4g\n", to, p.mis.uniform_fraction);
  const double ref = table_integral(p), stand_in = stand_in_integral(p);
  const int runs = 64;
  const std::uint64_t n = 1024;
  for (int e = 0; e < kDeviceEstimators; ++e) {
    const RunSums s = integrate_device(device(), p, Estimator(e), runs, n, kSeed);
    const Stats st = stats(s);
    const double target = uses_table(Estimator(e)) ? ref : stand_in;
    const double se = st.sd / std::sqrt(double(runs));
    const double z = se > 0 ? (st.mean - target) / se : 0.0;
    std::printf("converge_test: %s %s%s theta_o %.3f: %-13s mean %.7g target %.7g (reference %.7g) z %+.2f rel_se %.2e\n",
                domain_name(fx.domain).c_str(), light.name.c_str(), power ? " (power)" : "", to,
                estimator_name(Estimator(e)), st.mean, target, ref, z, se / target);
    INFO(estimator_name(Estimator(e)) << " seed " << kSeed << ": mean " << st.mean << " target " << target << " z " << z);
    CHECK(std::abs(st.mean - target) <= 4 * se + 2e-6 * target);
    if (Estimator(e) == Estimator::IsGmm) {
      // is_gmm's bias against the table's integral is the stand-in's integral error,
      // and with constant lighting this fixture makes that error far larger than the noise.
      if (light.is_constant()) CHECK(std::abs(stand_in - ref) > 10 * se);
      CHECK(std::abs((st.mean - ref) - (stand_in - ref)) <= 4 * se + 2e-6 * ref);
    }
  }
}

}  // namespace

TEST_CASE("stand-in integral: exact (normal CDFs) equals quadrature", "[converge]") {
  const TableReader table(fiber().table);
  const mix::MixtureSet set = to_mixture_set(read_mixture_file(fiber().mixture));
  Problem p = make_problem(table, set, 0.25, 0.4, default_lighting(Domain::Fiber, 1.0), 0.1);
  const double exact = stand_in_integral(p);
  Lighting almost = sky(Domain::Fiber);  // not constant: forces the quadrature path
  almost.constant = 1.0;
  almost.lobes[0].radiance = 0;
  almost.gradient = false;
  almost.lobes[0].kappa = 1e-6;
  p.light = almost;
  CHECK(stand_in_integral(p) == Approx(exact).epsilon(2e-4));
  // on the disk the components are not normals in theta and the base has mass too: the
  // constant-light integral is the quadrature's
  const TableReader hemi(hemisphere().table);
  mix::MixtureSet disk;
  disk.domain = Domain::Hemisphere;
  disk.map = mix::Map::Disk;
  disk.grid_theta_o = hemi.meta().theta_o;
  disk.grid_phi_o = {0.0};
  for (const double to : disk.grid_theta_o) {
    mix::SliceMixture sm = mix::make_slice_mixture({1.0}, {0.4, 0.3}, {0.05, 0.0, 0.08});
    sm.map = mix::Map::Disk;
    sm.base = 0.6;  // of the slice's mass, beside the Gaussian's 0.4 (prepare normalizes)
    sm.theta_o = to;
    sm.scale = 2.0;
    disk.slices.push_back(sm);
  }
  disk.prepare();
  Problem h = make_problem(hemi, disk, disk.grid_theta_o[1], 0.0, default_lighting(Domain::Hemisphere, 1.0), 0.1);
  const double closed = stand_in_integral(h);
  Lighting flat = sky(Domain::Hemisphere);
  flat.constant = 1.0;
  flat.lobes[0].radiance = 0;
  flat.gradient = false;
  flat.lobes[0].kappa = 1e-6;
  h.light = flat;
  CHECK(closed == Approx(stand_in_integral(h)).epsilon(2e-3));
  CHECK(closed == Approx(2.0).epsilon(0.02));  // scale x the mixture's mass on the hemisphere (nearly all of it)
  // and the table reference with constant L is the sum of f times the exact cell integrals
  Problem q = make_problem(table, set, 0.25, 0.4, default_lighting(Domain::Fiber, 2.0), 0.1);
  double s = 0;
  for (std::size_t i = 0; i < q.table.n_theta; ++i)
    for (std::size_t j = 0; j < q.table.n_phi; ++j) s += 2.0 * q.table.f[i * q.table.n_phi + j] * q.table.cell_weight(i);
  CHECK(table_integral(q) == Approx(s).epsilon(1e-12));
}

TEST_CASE("every table estimator is unbiased; is_gmm converges to the stand-in (fiber, constant)", "[converge]") {
  check_unbiased(fiber(), default_lighting(Domain::Fiber, 1.0), 0.25, 0.4);
}

TEST_CASE("every table estimator is unbiased; is_gmm converges to the stand-in (fiber, sky)", "[converge]") {
  check_unbiased(fiber(), sky(Domain::Fiber), -0.7, 2.5);
}

TEST_CASE("every table estimator is unbiased; is_gmm converges to the stand-in (hemisphere, sky)", "[converge]") {
  check_unbiased(hemisphere(), sky(Domain::Hemisphere), 0.5, -1.0);
}

TEST_CASE("every table estimator is unbiased under an environment map (fiber and hemisphere)", "[converge]") {
  check_unbiased(fiber(), map(Domain::Fiber), 0.3, -0.8);
  check_unbiased(hemisphere(), map(Domain::Hemisphere), 0.6, 0.4);
}

TEST_CASE("the MIS estimators are unbiased with the power heuristic too", "[converge]") {
  check_unbiased(hemisphere(), sky(Domain::Hemisphere), 0.5, -1.0, true);
}

TEST_CASE("device estimators agree with the CPU reference run for run", "[converge]") {
  for (const Fixture* fx : {&fiber(), &hemisphere()}) {
    const TableReader table(fx->table);
    const mix::MixtureSet set = to_mixture_set(read_mixture_file(fx->mixture));
    const mix::SliceMixture lm = light_mixture(*fx, sky(fx->domain));
    const Problem p = make_problem(table, set, 0.4, 0.9, sky(fx->domain), MisOptions{}, &lm);
    for (int e = 0; e < kDeviceEstimators; ++e) {
      const RunSums a = integrate_cpu(p, Estimator(e), 4, 512, kSeed);
      const RunSums b = integrate_device(device(), p, Estimator(e), 4, 512, kSeed, 64);
      REQUIRE(a.levels == b.levels);
      double worst = 0;
      for (int r = 0; r < 4; ++r)
        for (int l = 0; l < a.levels; ++l) {
          const double d = std::abs(a.at(r, l) - b.at(r, l)) / std::max(std::abs(a.at(r, l)), 1e-3);
          worst = std::max(worst, d);
        }
      std::printf("converge_test: device vs CPU %s %-13s: worst relative difference of run sums %.2e\n",
                  domain_name(fx->domain).c_str(), estimator_name(Estimator(e)), worst);
      CHECK(worst < 2e-3);
    }
  }
}

TEST_CASE("results do not depend on the chunking", "[converge]") {
  const TableReader table(fiber().table);
  const mix::MixtureSet set = to_mixture_set(read_mixture_file(fiber().mixture));
  const Problem p = make_problem(table, set, 0.1, 0.0, sky(Domain::Fiber), 0.1);
  const RunSums a = integrate_device(device(), p, Estimator::MisTab, 8, 2048, kSeed, 256);
  const RunSums b = integrate_device(device(), p, Estimator::MisTab, 8, 2048, kSeed, 16);
  for (int r = 0; r < 8; ++r)
    for (int l = 0; l < a.levels; ++l) CHECK(a.at(r, l) == Approx(b.at(r, l)).epsilon(1e-4));
}

TEST_CASE("scenes: PFM environment map, frame, errors naming file and key", "[converge]") {
  const fs::path dir = temp_dir();
  PfmImage img;
  img.width = 16;
  img.height = 8;
  for (int y = 0; y < 8; ++y)
    for (int x = 0; x < 16; ++x) img.luminance.push_back(0.5f + 0.4f * std::sin(0.4f * x) * std::cos(0.3f * y));
  const std::string pfm = (dir / "env.pfm").string();
  write_pfm(pfm, img);
  const PfmImage back = read_pfm(pfm);
  REQUIRE(back.width == 16);
  REQUIRE(back.height == 8);
  CHECK(back.luminance == img.luminance);

  const std::string scene_file = (dir / "env.yaml").string();
  std::ofstream(scene_file) << "name: envtest\nframe:\n  tangent: [0, 1, 0]\n  normal: [0, 0, 1]\nenvmap:\n  file: env.pfm\n  scale: 2\n";
  const Lighting l = parse_scene(YAML::LoadFile(scene_file), scene_file, "", Domain::Fiber);
  CHECK(l.name == "envtest");
  CHECK(l.env_width == 16);
  // theta = pi/2 is along the fiber tangent (+y): the map's value there
  const Vec3 w = l.to_world(kPi / 2, 0.0);
  CHECK(w[1] == Approx(1.0));
  check_unbiased(fiber(), l, 0.3, 0.0);

  auto error_of = [&](const std::string& yaml) {
    try {
      parse_scene(YAML::Load(yaml), "bad.yaml", "", Domain::Fiber);
    } catch (const ConfigError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  CHECK_THAT(error_of("lobes:\n  - direction: [0, 0, 1]\n    radius: 3\n    radiance: 1\n"),
             Catch::Contains("bad.yaml: lobes[0].radius") && Catch::Contains("unknown key"));
  CHECK_THAT(error_of("lobes:\n  - direction: [0, 0]\n    kappa: 3\n    radiance: 1\n"),
             Catch::Contains("lobes[0].direction") && Catch::Contains("3-vector"));
  CHECK_THAT(error_of("envmap:\n  file: nowhere.pfm\n"), Catch::Contains("envmap.file") && Catch::Contains("nowhere.pfm: no such file"));
  CHECK_THAT(error_of("frame:\n  tangent: [1, 0, 0]\n  normal: [2, 0, 0]\n"), Catch::Contains("parallel"));
  CHECK_THAT(error_of("sky: 1\n"), Catch::Contains("bad.yaml: sky") && Catch::Contains("unknown key"));
  std::ofstream(dir / "broken.pfm") << "P6\n1 1\n255\n";
  CHECK_THROWS_WITH(read_pfm((dir / "broken.pfm").string()), Catch::Contains("not a PFM"));
}

TEST_CASE("bsdfmix converge writes the convergence CSV with the exact columns", "[converge][cli]") {
  const fs::path dir = temp_dir();
  const std::string cfg = (dir / "cfg.yaml").string(), csv = (dir / "conv.csv").string();
  std::ofstream(cfg) << "table: " << fiber().table << "\nconverge:\n  mixture: " << fiber().mixture
                     << "\n  theta_o: [0.0, 0.5]\n  samples_max: 100\n  runs: 4\n  uniform_fraction: earned\n  csv: " << csv
                     << "\n  scene:\n    - {name: sky, constant: 0.5, gradient: {zenith: 1, horizon: 0.5, ground: 0.1}}\n"
                        "    - {name: flat, constant: 1}\n";
  REQUIRE(std::system((std::string(BSDFMIX_BINARY) + " converge -q " + cfg).c_str()) == 0);
  std::ifstream in(csv);
  std::string line;
  std::getline(in, line);
  CHECK(line == "table,theta_o,phi_o,scene,estimator,samples,runs,mean,reference,rmse,rel_rmse,ns_per_sample,"
                "uniform_fraction");
  int rows = 0;
  const mix::MixtureSet set = to_mixture_set(read_mixture_file(fiber().mixture));
  while (std::getline(in, line)) {
    ++rows;
    CHECK(std::count(line.begin(), line.end(), ',') == 12);
    // the share used: the earned one at the row's direction
    const double theta_o = std::stod(line.substr(line.find(',') + 1));
    CHECK(std::stod(line.substr(line.rfind(',') + 1)) == Approx(set.defensive(theta_o, 0.0)).margin(1e-9));
  }
  CHECK(rows == 2 * 2 * 11 * 7);  // directions x scenes x estimators (the default under a scene) x N in 1..64
  std::ifstream tail((dir / "conv_tail.csv").string());
  std::getline(tail, line);
  CHECK(line == kTailHeader);
  // a bad estimator name is one error line naming the key
  std::ofstream(cfg) << "table: " << fiber().table << "\nconverge:\n  mixture: " << fiber().mixture
                     << "\n  estimators: [us_tab, magic]\n  csv: " << csv << "\n";
  CHECK(std::system((std::string(BSDFMIX_BINARY) + " converge -q " + cfg + " 2>/dev/null").c_str()) != 0);
}

TEST_CASE("bsdfmix converge fits the lighting as BSDFMIX_POOL_LOG says", "[converge][cli]") {
  // The variable, read once by the command, reaches the engine of the lighting's fit.
  const fs::path dir = temp_dir();
  const std::string cfg = (dir / "pool_cfg.yaml").string(), err = (dir / "pool.log").string();
  const fs::path cache = dir / "pool_light_cache";
  fs::remove_all(cache);
  std::ofstream(cfg) << "table: " << fiber().table << "\nconverge:\n  mixture: " << fiber().mixture
                     << "\n  theta_o: [0.5]\n  samples_max: 16\n  runs: 2\n  csv: " << (dir / "pool.csv").string()
                     << "\n  light_mixture_dir: " << cache.string()
                     << "\n  scene:\n    - {name: sky, constant: 0.5, gradient: {zenith: 1, horizon: 0.5, ground: 0.1}}\n"
                        "  estimators: [mis_product]\n";
  const std::string converge = std::string(BSDFMIX_BINARY) + " converge -q " + cfg + " 2> " + err;
  const auto pool_lines = [&err] {
    std::ifstream in(err);
    const std::string text{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
    return text.find("pool em batch") != std::string::npos;
  };
  REQUIRE(std::system(("BSDFMIX_POOL_LOG=1 " + converge).c_str()) == 0);
  CHECK(pool_lines());
  fs::remove_all(cache);
  REQUIRE(std::system(converge.c_str()) == 0);  // without it: the same fit, no pool lines
  CHECK_FALSE(pool_lines());
}

namespace {

std::string rgl_file(const std::string& name) { return std::string(BSDFMIX_SOURCE_DIR) + "/data/rgl/" + name; }

// A coarse import of satin_rosaline (4 theta_o x 32 theta_i x 64 phi_i) and a mixture for
// it: per slice a broad Gaussian and one near the mirror direction (any mixture will do:
// the RGL estimators draw with the file's warps, f is the table's).
struct RglFixture {
  std::string table, mixture, rgl;
};

const RglFixture& satin() {
  static const RglFixture fx = [] {
    Progress::set_enabled(false);
    RglFixture f{(temp_dir() / "satin.h5").string(), (temp_dir() / "satin_mixture.h5").string(),
                 rgl_file("satin_rosaline_rgb.bsdf")};
    RglImportOptions o;
    o.file = f.rgl;
    o.n_theta_o = 4;
    o.n_theta_i = 32;
    o.n_phi_i = 64;
    import_rgl_table(o, f.table);
    const TableReader t(f.table);
    MixtureFile m;
    m.domain = Domain::Hemisphere;
    m.azimuthal = true;
    m.table_theta_o = t.meta().theta_o;
    m.table_phi_o = t.meta().phi_o;
    for (const double to : t.meta().theta_o)
      m.add_slice(to, 0.0, 1.0, 0.0, 0.05, {0.7, 0.3}, {0.7, 0.0, to, 3.0}, {0.5, 0.0, 4.0, 0.05, 0.0, 0.2});
    write_mixture_file(f.mixture, m);
    return f;
  }();
  return fx;
}

Lighting sky_scene() {
  const std::string path = std::string(BSDFMIX_SOURCE_DIR) + "/configs/scenes/sky.yaml";
  return parse_scene(YAML::LoadFile(path), path, "", Domain::Hemisphere);
}

}  // namespace

TEST_CASE("is_rgl and mis_light_rgl converge to the table's integral (constant light and the sky)", "[converge][rgl]") {
  const RglFixture& fx = satin();
  const TableReader table(fx.table);
  const mix::MixtureSet set = to_mixture_set(read_mixture_file(fx.mixture));
  const RglBrdf brdf(fx.rgl);
  Lighting constant = default_lighting(Domain::Hemisphere, 1.0);
  constant.name = "constant";
  const Lighting sky = sky_scene();
  const int runs = 16;
  const std::uint64_t n = 8192;
  // between slices, phi_o turning the frame (azimuthal symmetry)
  for (const auto& [to, po] : {std::pair<double, double>{0.3, 0.0}, std::pair<double, double>{0.95, 0.7}})
    for (const Lighting* light : std::initializer_list<const Lighting*>{&constant, &sky})
      for (const bool power : {false, true}) {
        if (power && light == &constant) continue;
        MisOptions mis;
        mis.power = power;
        Problem p = make_problem(table, set, to, po, *light, mis, nullptr);
        p.rgl = &brdf;
        const double ref = table_integral(p);
        REQUIRE(ref > 0);
        for (const Estimator e : {Estimator::IsRgl, Estimator::MisLightRgl}) {
          if (power && e == Estimator::IsRgl) continue;
          const Stats st = stats(integrate_cpu(p, e, runs, n, kSeed));
          const double se = st.sd / std::sqrt(double(runs));
          std::printf("converge_test: satin %s%s theta_o %.2f phi_o %.2f: %-13s mean %.7g reference %.7g z %+.2f\n",
                      light->name.c_str(), power ? " (power)" : "", to, po, estimator_name(e), st.mean, ref,
                      se > 0 ? (st.mean - ref) / se : 0.0);
          INFO(estimator_name(e) << " under " << light->name << " at theta_o " << to << ": mean " << st.mean
                                 << " reference " << ref << " se " << se);
          CHECK(se > 0);
          CHECK(std::abs(st.mean - ref) <= 4 * se + 1e-6 * ref);
        }
        // from the cell probabilities (deterministic): the warps reach every cell where f > 0;
        // under constant light they follow the table's lobe (rotated with phi_o as the table
        // is) far better than uniform sampling, and under the sky light sampling helps them
        const LightTail lt = light_tail(p, {Estimator::UsTab, Estimator::IsRgl, Estimator::MisLightRgl});
        std::printf("converge_test: satin %s theta_o %.2f phi_o %.2f: relvar us_tab %.4g is_rgl %.4g mis_light_rgl %.4g, "
                    "missed %.3g %.3g\n", light->name.c_str(), to, po, lt.relvar[0], lt.relvar[1], lt.relvar[2],
                    lt.missed[1], lt.missed[2]);
        CHECK(lt.missed[1] < 1e-9);
        CHECK(lt.missed[2] < 1e-9);
        if (light->is_constant()) CHECK(lt.relvar[1] < 0.1 * lt.relvar[0]);
        else CHECK(lt.relvar[2] < 0.5 * lt.relvar[1]);
        // what is_rgl draws has the density estimator_pdf gives (the file's warps' pdf)
        const RglBrdf::Sample s = brdf.sample({std::sin(to), 0.0, std::cos(to)}, 0.3, 0.6);
        REQUIRE(s.valid);
        double th = 0, ph = 0;
        const double u[4] = {0.9, 0.3, 0.6, 0.1};
        REQUIRE(draw_cpu(p, Estimator::IsRgl, u, th, ph));
        CHECK(std::cos(th) == Approx(s.omega_i[2]).epsilon(1e-9));
        CHECK(wrap_phi(ph - po) == Approx(std::atan2(s.omega_i[1], s.omega_i[0])).margin(1e-9));
        CHECK(estimator_pdf(p, Estimator::IsRgl, th, ph) == Approx(s.pdf).epsilon(1e-6));
        // the light fraction splits mis_light_rgl's density
        const double pl = estimator_pdf(p, Estimator::Light, th, ph);
        CHECK(estimator_pdf(p, Estimator::MisLightRgl, th, ph) ==
              Approx(mis.light_fraction * pl + (1 - mis.light_fraction) * s.pdf).epsilon(1e-9));
      }
}

TEST_CASE("the RGL estimators have no kernel; they need the table's own RGL file", "[converge][rgl]") {
  Progress::set_enabled(false);
  const RglFixture& fx = satin();
  const TableReader table(fx.table);
  const mix::MixtureSet set = to_mixture_set(read_mixture_file(fx.mixture));
  const RglBrdf brdf(fx.rgl);
  Problem p = make_problem(table, set, 0.5, 0.0, default_lighting(Domain::Hemisphere, 1.0), MisOptions{}, nullptr);
  p.rgl = &brdf;
  CHECK_THROWS_WITH(integrate_device(device(), p, Estimator::IsRgl, 2, 64, kSeed),
                    Catch::Contains("is_rgl has no kernel"));
  CHECK_FALSE(on_device(Estimator::IsRgl));
  CHECK_FALSE(on_device(Estimator::MisLightRgl));
  CHECK(on_device(Estimator::MisProduct));
  CHECK(int(Estimator::MisProduct) == 10);  // kernels/sample.cl's numbers stay
  CHECK(parse_estimator("is_rgl", "x") == Estimator::IsRgl);
  CHECK(parse_estimator("mis_light_rgl", "x") == Estimator::MisLightRgl);
  CHECK(uses_lighting(Estimator::MisLightRgl));
  CHECK_FALSE(uses_lighting(Estimator::IsRgl));

  StudySpec spec;
  spec.mixture = fx.mixture;
  spec.table_label = "satin";
  spec.directions = {{0.5, 0.0}};
  spec.scenes = {default_lighting(Domain::Hemisphere, 1.0)};
  spec.estimators = {Estimator::IsRgl};
  spec.runs = 2;
  spec.samples_max = 16;
  spec.cpu = true;
  spec.csv = (temp_dir() / "rgl_errors.csv").string();
  spec.tail_csv = (temp_dir() / "rgl_errors_tail.csv").string();
  spec.table = fx.table;
  // no file
  CHECK_THROWS_WITH(run_study(spec), Catch::Contains("converge.rgl: is_rgl and mis_light_rgl sample with an RGL file"));
  // another material's file
  spec.rgl = rgl_file("paper_white_rgb.bsdf");
  CHECK_THROWS_WITH(run_study(spec), Catch::Contains("paper_white_rgb.bsdf: sha256") &&
                                         Catch::Contains("differs from that of the file"));
  // a table that no RGL file made
  spec.rgl = fx.rgl;
  spec.table = hemisphere().table;
  spec.mixture = hemisphere().mixture;
  CHECK_THROWS_WITH(run_study(spec), Catch::Contains("not imported from an RGL file"));
  // and the right pair runs
  spec.table = fx.table;
  spec.mixture = fx.mixture;
  CHECK(run_study(spec).size() == 5);  // N = 1 .. 16
}

TEST_CASE("bsdfmix converge writes the rows of is_rgl and mis_light_rgl", "[converge][cli][rgl]") {
  const RglFixture& fx = satin();
  const fs::path dir = temp_dir();
  const std::string cfg = (dir / "rgl_cfg.yaml").string(), csv = (dir / "rgl_conv.csv").string();
  const std::string sky_file = std::string(BSDFMIX_SOURCE_DIR) + "/configs/scenes/sky.yaml";
  const auto write_cfg = [&](const std::string& rgl_line) {
    std::ofstream(cfg) << "table: " << fx.table << "\nconverge:\n  mixture: " << fx.mixture
                       << "\n  theta_o: [0.4]\n  phi_o: [0.5]\n  samples_max: 64\n  runs: 4\n  csv: " << csv
                       << "\n  scene: " << sky_file << "\n  estimators: [mis_light_cdf, is_rgl, mis_light_rgl]\n"
                       << rgl_line;
  };
  write_cfg("  rgl: " + fx.rgl + "\n");
  fs::remove(csv);
  REQUIRE(std::system((std::string(BSDFMIX_BINARY) + " converge -q " + cfg).c_str()) == 0);
  std::ifstream in(csv);
  std::string line;
  std::getline(in, line);
  CHECK(line == kConvergenceHeader);
  std::map<std::string, int> rows;
  while (std::getline(in, line)) {
    std::vector<std::string> cells;
    std::stringstream ss(line);
    for (std::string c; std::getline(ss, c, ',');) cells.push_back(c);
    REQUIRE(cells.size() == 13);
    ++rows[cells[4]];
    CHECK(std::isfinite(std::stod(cells[7])));  // mean
    CHECK(std::stod(cells[8]) > 0);             // reference
  }
  CHECK(rows["is_rgl"] == 7);  // N = 1 .. 64
  CHECK(rows["mis_light_rgl"] == 7);
  CHECK(rows["mis_light_cdf"] == 7);
  // without converge.rgl, the file of the config's import section (the table exists: no import)
  write_cfg("import:\n  rgl: " + fx.rgl + "\n  theta_o: 4\n  theta_i: 32\n  phi_i: 64\n");
  fs::remove(csv);
  CHECK(std::system((std::string(BSDFMIX_BINARY) + " converge -q " + cfg).c_str()) == 0);
  CHECK(fs::exists(csv));
  // without the file: one error line naming the key
  const std::string err = (dir / "rgl_err.txt").string();
  write_cfg("");
  CHECK(std::system((std::string(BSDFMIX_BINARY) + " converge -q " + cfg + " 2>" + err).c_str()) != 0);
  std::ifstream e1(err);
  std::getline(e1, line);
  CHECK_THAT(line, Catch::Contains("converge.rgl") && Catch::Contains("is_rgl samples with an RGL file's own warps"));
  CHECK_FALSE(std::getline(e1, line));
  // another material's file: one error line naming both hashes' files
  write_cfg("  rgl: " + rgl_file("paper_white_rgb.bsdf") + "\n");
  CHECK(std::system((std::string(BSDFMIX_BINARY) + " converge -q " + cfg + " 2>" + err).c_str()) != 0);
  std::ifstream e2(err);
  std::getline(e2, line);
  CHECK_THAT(line, Catch::Contains("paper_white_rgb.bsdf: sha256") && Catch::Contains(fx.table));
  CHECK_FALSE(std::getline(e2, line));
}

// The lighting's mixture follows L per unit of its plane: over (theta, phi) in
// (theta, phi), per steradian on the disk, so that its product with a BSDF mixture in the
// same plane follows the integrand there. A constant L is flat in either plane; a
// mixture of L per unit of (theta, phi) placed on the disk would grow like 1 / sin theta.
TEST_CASE("the lighting's mixture follows L per unit of its plane: (theta, phi) or the disk", "[converge][light]") {
  Progress::set_enabled(false);
  const TableMeta grid = make_grid(Domain::Hemisphere, 1, 1, 24, 48, true);
  Lighting l = default_lighting(Domain::Hemisphere, 1.0);
  l.name = "flat";
  FitSettings fit;
  fit.k_max = 6;
  for (const std::string& map : {std::string("theta_phi"), std::string("equal_area")}) {
    CAPTURE(map);
    fit.map = map;
    const mix::SliceMixture m = lighting_mixture(l, grid, fit, (temp_dir() / "flat_light_cache").string(), "").mixture;
    const bool disk = map == "equal_area";
    // the integral of L = 1: over (theta, phi) pi^2, over the hemisphere's solid angle 2 pi
    // (the scale is the amplitude fit's, within a few percent of it)
    CHECK(m.scale == Approx(disk ? 2 * kPi : kPi * kPi).epsilon(0.1));
    for (const double theta : {0.25, 0.7, 1.2}) {
      const double flat = disk ? 1 / (2 * kPi) : 1 / (kPi * kPi);
      double x = theta, y = 0.4;
      if (disk) mix::to_map(mix::Map::Disk, theta, 0.4, x, y);
      CAPTURE(theta);
      CHECK(m.pdf_map(x, y) == Approx(flat).epsilon(0.2));
    }
  }
  CHECK_THROWS_AS(lighting_mixture(l, grid, with_map(fit, "auto"), (temp_dir() / "flat_light_cache").string(), ""),
                  std::logic_error);
}
