// RGL measured BRDFs: the tensor container, the warps, f in our direction convention
// (albedo, reciprocity), the imported table, and every malformed-file rejection.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

#include "core/atomic_file.hpp"
#include "core/domain.hpp"
#include "core/error.hpp"
#include "core/progress.hpp"
#include "io/table.hpp"
#include "chi_square.hpp"
#include "tables/rgl_brdf.hpp"
#include "tables/rgl_file.hpp"
#include "tables/rgl_import.hpp"
#include "tables/rgl_lobe.hpp"

using namespace bsdfmix;
using Catch::Matchers::Contains;
namespace fs = std::filesystem;

namespace {

const char* kFiles[] = {"cg_sunflower_rgb", "paper_white_rgb", "satin_rosaline_rgb", "cc_iris_purple_gem_rgb"};

std::string rgl_path(const std::string& stem) {
  return std::string(BSDFMIX_SOURCE_DIR) + "/data/rgl/" + stem + ".bsdf";
}

std::string temp_path(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / "bsdfmix_rgl_test";
  fs::create_directories(dir);
  return (dir / name).string();
}

double deg(double d) { return d * kPi / 180.0; }

// Albedo for the view direction theta_o (phi_o = 0): the sum of the integrand weights of
// f over a theta_i x phi_i grid of cell centers (midpoint rule).
double albedo(const RglBrdf& brdf, double theta_o, std::size_t n_t, std::size_t n_p) {
  const TableMeta g = make_grid(Domain::Hemisphere, 1, 1, n_t, n_p, true);
  std::vector<float> f(n_t * n_p);
  for (std::size_t t = 0; t < n_t; ++t)
    for (std::size_t p = 0; p < n_p; ++p) f[t * n_p + p] = float(brdf.eval(theta_o, 0.0, g.theta_i[t], g.phi_i[p]).y);
  double sum = 0.0;
  for (double w : integrand_weights(Domain::Hemisphere, g.theta_i, g.phi_i, f.data())) sum += w;
  return sum;
}

// A field to write back into a tensor file: header data and its bytes.
struct RawField {
  std::string name;
  std::uint8_t dtype;
  std::vector<std::uint64_t> shape;
  std::vector<std::uint8_t> data;
};

std::vector<RawField> raw_fields(const RglFile& f) {
  std::vector<RawField> out;
  for (const auto& fd : f.fields())
    out.push_back({fd.name, fd.dtype, fd.shape,
                   std::vector<std::uint8_t>(f.bytes().begin() + long(fd.offset),
                                             f.bytes().begin() + long(fd.offset + fd.bytes()))});
  return out;
}

RawField* find(std::vector<RawField>& fields, const std::string& name) {
  for (auto& f : fields)
    if (f.name == name) return &f;
  FAIL("no field " << name);
  return nullptr;
}

template <class T>
void put(std::vector<std::uint8_t>& b, T v) {
  for (std::size_t k = 0; k < sizeof(T); ++k) b.push_back(std::uint8_t(std::uint64_t(v) >> (8 * k)));
}

// Serializes fields into the tensor file layout (version major.minor).
std::vector<std::uint8_t> tensor_bytes(const std::vector<RawField>& fields, int major = 1, int minor = 0) {
  std::vector<std::uint8_t> b(std::begin("tensor_file"), std::end("tensor_file"));  // 12 bytes with the NUL
  b.push_back(std::uint8_t(major));
  b.push_back(std::uint8_t(minor));
  put<std::uint32_t>(b, std::uint32_t(fields.size()));
  std::size_t header = b.size();
  for (const auto& f : fields) header += 2 + f.name.size() + 2 + 1 + 8 + 8 * f.shape.size();
  std::uint64_t offset = (header + 7) / 8 * 8;
  for (const auto& f : fields) {
    put<std::uint16_t>(b, std::uint16_t(f.name.size()));
    b.insert(b.end(), f.name.begin(), f.name.end());
    put<std::uint16_t>(b, std::uint16_t(f.shape.size()));
    b.push_back(f.dtype);
    put<std::uint64_t>(b, offset);
    for (auto s : f.shape) put<std::uint64_t>(b, s);
    offset += (f.data.size() + 7) / 8 * 8;
  }
  for (const auto& f : fields) {
    while (b.size() % 8) b.push_back(0);
    b.insert(b.end(), f.data.begin(), f.data.end());
  }
  return b;
}

std::string write_bytes(const std::string& name, const std::vector<std::uint8_t>& b) {
  const std::string p = temp_path(name);
  std::ofstream(p, std::ios::binary).write(reinterpret_cast<const char*>(b.data()), std::streamsize(b.size()));
  return p;
}

std::vector<std::uint8_t> float_bytes(const std::vector<float>& v) {
  std::vector<std::uint8_t> b(v.size() * 4);
  std::memcpy(b.data(), v.data(), b.size());
  return b;
}

// The expected message of loading `path` must name the file and the problem.
void check_rejected(const std::string& path, const std::string& problem) {
  INFO("file " << path);
  try {
    RglBrdf brdf(path);
    FAIL("accepted a malformed file, expected: " << problem);
  } catch (const InputError& e) {
    const std::string msg = e.what();
    INFO("message: " << msg);
    CHECK_THAT(msg, Contains(path) && Contains(problem));
    CHECK(msg.find('\n') == std::string::npos);
  }
}

}  // namespace

TEST_CASE("sha256 of known vectors and of the data files", "[rgl]") {
  CHECK(sha256_hex({}) == "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
  const std::string abc = "abc";
  CHECK(sha256_hex(std::vector<std::uint8_t>(abc.begin(), abc.end())) ==
        "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  // Values of data/rgl/PROVENANCE.md.
  CHECK(RglBrdf(rgl_path("paper_white_rgb")).sha256() ==
        "9d641fbb56358275509b2b1053d1002313e2dabc7b3ec202eb5c5a6943f7b70e");
  CHECK(RglBrdf(rgl_path("satin_rosaline_rgb")).sha256() ==
        "6a9e7bdff6210969d97522cf7e3f615f3cb50ed4022b517eebda17f93b8e20e0");
  CHECK(RglBrdf(rgl_path("cg_sunflower_rgb")).sha256() ==
        "ce817d04568c39284908ce89b12989e68d6407ee48fb44f6cc644e7bfdf7c840");
  CHECK(RglBrdf(rgl_path("cc_iris_purple_gem_rgb")).sha256() ==
        "3e87004db0f7395365f93addb21042505e7531935645653b6fa0c7180b021500");
}

TEST_CASE("the tensor container of the three files", "[rgl]") {
  for (const char* stem : kFiles) {
    INFO(stem);
    RglFile f(rgl_path(stem));
    CHECK(f.version_major() == 1);
    CHECK(f.version_minor() == 0);
    for (const char* name : {"theta_i", "phi_i", "ndf", "sigma", "vndf", "luminance", "rgb", "jacobian"})
      CHECK(f.find(name) != nullptr);
    CHECK(f.field("theta_i").shape == std::vector<std::uint64_t>{8});
    CHECK(f.field("phi_i").shape == std::vector<std::uint64_t>{1});
    RglBrdf b(rgl_path(stem));
    CHECK(b.n_theta() == 8);
    CHECK(!b.description().empty());
  }
}

TEST_CASE("the VNDF warp: sample and invert are inverse maps, densities agree", "[rgl]") {
  RglFile f(rgl_path("satin_rosaline_rgb"));
  const RglField& fv = f.field("vndf");
  RglWarp2D w(f.as_double(fv), fv.shape[3], fv.shape[2],
              {f.as_double(f.field("phi_i")), f.as_double(f.field("theta_i"))}, true);
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> U(0.02, 0.98);
  double worst = 0.0, worst_pdf = 0.0;
  for (int k = 0; k < 2000; ++k) {
    const double param[2] = {0.0, U(rng) * 1.5};
    const double u = U(rng), v = U(rng);
    const auto s = w.sample(u, v, param);
    const auto back = w.invert(s[0], s[1], param);
    worst = std::max({worst, std::abs(back[0] - u), std::abs(back[1] - v)});
    worst_pdf = std::max(worst_pdf, std::abs(s[2] - back[2]) / std::max(1e-9, s[2]));
    CHECK(std::abs(w.eval(s[0], s[1], param) - s[2]) <= 1e-9 * std::max(1.0, s[2]));
  }
  INFO("max |invert(sample(u)) - u| = " << worst << ", max pdf rel diff " << worst_pdf);
  CHECK(worst < 1e-6);
  CHECK(worst_pdf < 1e-6);
}

TEST_CASE("the sampling density of the warps integrates to at most 1", "[rgl]") {
  // Mitsuba's pdf over the light direction; the mass that maps below the horizon is lost,
  // so the integral is <= 1, and close to 1 where little of it does (view near the normal).
  for (const char* stem : kFiles) {
    RglBrdf b(rgl_path(stem));
    for (double to : {0.0, 30.0, 60.0}) {
      const std::array<double, 3> wo = {std::sin(deg(to)), 0.0, std::cos(deg(to))};
      const TableMeta g = make_grid(Domain::Hemisphere, 1, 1, 256, 512, true);
      double sum = 0.0;
      const double dt = kPi / 2 / 256, dp = 2 * kPi / 512;
      for (double ti : g.theta_i)
        for (double pi : g.phi_i)
          sum += b.pdf(wo, {std::sin(ti) * std::cos(pi), std::sin(ti) * std::sin(pi), std::cos(ti)}) *
                 std::sin(ti) * dt * dp;
      INFO(stem << " theta_o " << to << ": integral of pdf = " << sum);
      std::printf("rgl_test: %s theta_o %2.0f: integral of the pdf %.5f\n", stem, to, sum);
      CHECK(sum <= 1.005);  // measured 0.983 to 1.002 (docs/rgl.md); a pdf 10% off fails
      CHECK(sum >= 0.975);
    }
  }
}

// Albedo by importance sampling with the file's own warps: stratified n x n samples of
// f cos / pdf. Independent of any grid, so it resolves the sharp lobes the midpoint rule
// on a 90 x 180 grid underestimates (cg_sunflower by up to 6% near 60 degrees).
double albedo_is(const RglBrdf& b, double theta_o, int n) {
  const std::array<double, 3> wo = {std::sin(theta_o), 0.0, std::cos(theta_o)};
  double sum = 0.0;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const auto smp = b.sample(wo, (i + 0.5) / n, (j + 0.5) / n);
      if (smp.valid) sum += b.eval(wo, smp.omega_i).y * smp.omega_i[2] / smp.pdf;
    }
  return sum / (double(n) * n);
}

TEST_CASE("sampling the warps: pdf of the samples agrees with pdf()", "[rgl]") {
  for (const char* stem : kFiles) {
    RglBrdf b(rgl_path(stem));
    std::mt19937_64 rng(3);
    std::uniform_real_distribution<double> U(0.0, 1.0);
    double worst = 0.0;
    int valid = 0;
    for (int k = 0; k < 2000; ++k) {
      const double to = deg(80.0) * U(rng);
      const std::array<double, 3> wo = {std::sin(to), 0.0, std::cos(to)};
      const auto smp = b.sample(wo, U(rng), U(rng));
      if (!smp.valid) continue;
      ++valid;
      worst = std::max(worst, std::abs(b.pdf(wo, smp.omega_i) - smp.pdf) / smp.pdf);
    }
    INFO(stem << ": " << valid << " valid samples, max pdf rel diff " << worst);
    CHECK(valid > 1500);
    CHECK(worst < 1e-4);
  }
}

TEST_CASE("albedo at most 1 up to 75 degrees; grazing values reported", "[rgl]") {
  // Two estimates of the albedo integral of f cos over the light hemisphere:
  // - the imported table at the default resolution (90 x 90 x 180, 1 degree slices),
  //   sum of integrand weights: <= 1 + 0.005 (its own quadrature error against a converged
  //   1440 x 2880 grid: < 0.1% for paper_white, -1.2% for satin_rosaline at 75 degrees,
  //   +2% to -6% for cg_sunflower's sharp lobe, whose albedo is below 0.5);
  // - importance sampling with the warps (64 x 64 stratified): <= 1 + 0.01 at every
  //   degree from 0 to 75. satin_rosaline's converged albedo at 75 degrees is 1.0006
  //   (midpoint rule on 360 x 720), so 1% covers that measurement excess plus the
  //   estimator's error (<= 0.3% against a 1440 x 2880 midpoint rule).
  Progress::set_enabled(false);
  for (const char* stem : kFiles) {
    INFO(stem);
    const std::string out = temp_path(std::string(stem) + ".h5");
    RglImportOptions opt;
    opt.file = rgl_path(stem);
    opt.n_theta_o = 90;
    opt.n_theta_i = 90;
    opt.n_phi_i = 180;
    import_rgl_table(opt, out);
    TableReader r(out);
    const TableMeta& m = r.meta();
    CHECK(m.domain == Domain::Hemisphere);
    CHECK(m.azimuthal);
    CHECK(m.rgb);
    CHECK_THAT(m.source, Contains("\"model\": \"rgl\"") && Contains(std::string(stem) + ".bsdf") &&
                             Contains(RglBrdf(opt.file).sha256()));
    double max_le75 = 0.0, max_all = 0.0;
    for (std::size_t t = 0; t < m.theta_o.size(); ++t) {
      const auto v = r.read_slice(t, 0);  // checks NaN, Inf, negative
      double a = 0.0;
      for (double w : integrand_weights(m.domain, m.theta_i, m.phi_i, v.data())) a += w;
      max_all = std::max(max_all, a);
      if (m.theta_o[t] <= deg(75.0)) {
        max_le75 = std::max(max_le75, a);
        INFO("table slice theta_o " << m.theta_o[t] * 180 / kPi << " deg: albedo " << a);
        CHECK(a <= 1.005);
        CHECK(a > 0.01);
      }
    }
    RglBrdf b(opt.file);
    double max_is = 0.0;
    for (int d = 0; d <= 75; ++d) {
      const double a = albedo_is(b, deg(d), 64);
      INFO("importance-sampled albedo at " << d << " deg: " << a);
      CHECK(a <= 1.01);
      max_is = std::max(max_is, a);
    }
    std::ostringstream report;
    report << stem << " albedo (90x180 grid / importance sampled):";
    for (double to : {0.0, 45.0, 75.0, 85.0})
      report << "  " << to << " deg " << albedo(b, deg(to), 90, 180) << " / " << albedo_is(b, deg(to), 64);
    report << " | max <= 75 deg: table slices " << max_le75 << ", sampled " << max_is << "; all slices " << max_all;
    WARN(report.str());
  }
}

TEST_CASE("satin_rosaline exceeds albedo 1 at grazing view, kept as measured", "[rgl]") {
  RglBrdf b(rgl_path("satin_rosaline_rgb"));
  const double a85 = albedo(b, deg(85.0), 90, 180);
  WARN("satin_rosaline albedo at 85 deg: " << a85);
  CHECK(a85 > 1.0);
  CHECK(a85 < 1.3);
}

// f(a, b) against f(b, a) on 4000 random direction pairs up to 75 degrees: each pair's
// |f(a, b) - f(b, a)| / mean, sorted, and the sum of the differences over the sum of the
// means (the pairs weighted by f).
struct Reciprocity {
  std::vector<double> rel;
  double weighted = 0.0;
};

Reciprocity reciprocity(const RglBrdf& b) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  std::vector<double> rel;
  double diff = 0.0, mean = 0.0;
  for (int k = 0; k < 4000; ++k) {
    const double t1 = std::acos(1.0 - U(rng) * (1.0 - std::cos(deg(75)))), p1 = (2 * U(rng) - 1) * kPi;
    const double t2 = std::acos(1.0 - U(rng) * (1.0 - std::cos(deg(75)))), p2 = (2 * U(rng) - 1) * kPi;
    const double a = b.eval(t1, p1, t2, p2).y, c = b.eval(t2, p2, t1, p1).y;
    if (a + c <= 0.0) continue;
    rel.push_back(std::abs(a - c) / (0.5 * (a + c)));
    diff += std::abs(a - c);
    mean += 0.5 * (a + c);
  }
  std::sort(rel.begin(), rel.end());
  return {rel, diff / mean};
}

TEST_CASE("reciprocity within measurement tolerance", "[rgl]") {
  // f(omega_o, omega_i) vs f(omega_i, omega_o). The two values come from different view
  // elevations of the measurement (and different interpolation between its 8 of them), so
  // they agree to measurement accuracy only (docs/rgl.md gives the measured median and
  // 90th percentile). Bounds: 5% and 15%. Leaving the light cosine in f (Mitsuba's eval)
  // would make the median |cos a - cos b| / mean, about 40% on these pairs.
  // cc_iris_purple_gem's base is near black (the median pair's f about 1e-3 of its peak's
  // 10), where the measurement's noise is of the order of the value: its pairs differ by a
  // median 30%, and it is checked by the differences weighted by f instead (measured 15%;
  // the three others 2% to 10%; bound 25%).
  for (const char* stem : kFiles) {
    const Reciprocity r = reciprocity(RglBrdf(rgl_path(stem)));
    if (std::string(stem) == "cc_iris_purple_gem_rgb") {
      INFO(stem << " reciprocity: weighted relative difference " << r.weighted);
      CHECK(r.weighted < 0.25);
      continue;
    }
    const std::vector<double>& rel = r.rel;
    const double median = rel[rel.size() / 2], p90 = rel[rel.size() * 9 / 10];
    INFO(stem << " reciprocity: median relative difference " << median << ", 90th percentile " << p90 << " over "
              << rel.size() << " pairs");
    CHECK(median < 0.05);
    CHECK(p90 < 0.15);
  }
}

TEST_CASE("the direction convention: the view direction is the file's tabulated one", "[rgl]") {
  // The glossy peak of f lies in the mirror direction of the view.
  RglBrdf b(rgl_path("cg_sunflower_rgb"));
  for (double to_deg : {20.0, 40.0, 60.0}) {
    const double to = deg(to_deg);
    double best = 0.0, best_t = 0.0;
    for (int k = 1; k < 900; ++k) {
      const double ti = deg(k * 0.1);
      const double v = b.eval(to, 0.0, ti, -kPi).y;  // light in the plane, opposite azimuth
      if (v > best) best = v, best_t = ti;
    }
    INFO("view " << to_deg << " deg: peak at light " << best_t * 180 / kPi << " deg");
    CHECK(std::abs(best_t - to) < deg(1.5));
  }
  // Swapping the roles (the file's tabulated direction taken as the light, f divided by the
  // cosine of the view) changes the grazing albedo of satin_rosaline: the measured 1.1 at
  // 85 degrees belongs to the view direction being the tabulated one.
  RglBrdf s(rgl_path("satin_rosaline_rgb"));
  const TableMeta g = make_grid(Domain::Hemisphere, 1, 1, 90, 180, true);
  const double to = deg(85.0);
  double ours = 0.0, swapped = 0.0;
  const double cell = (kPi / 2 / 90) * (2 * kPi / 180);
  for (double ti : g.theta_i)
    for (double pi : g.phi_i) {
      const double w = std::cos(ti) * std::sin(ti) * cell;
      ours += s.eval(to, 0.0, ti, pi).y * w;
      // f_swapped(view, light) = f(light, view) * cos(view) / cos(light)
      swapped += s.eval(ti, pi, to, 0.0).y * std::cos(to) / std::cos(ti) * w;
    }
  WARN("satin_rosaline albedo at 85 deg: " << ours << " (directions swapped: " << swapped << ")");
  CHECK(ours == Approx(albedo(s, to, 90, 180)).epsilon(1e-5));
  CHECK(std::abs(ours - swapped) > 0.05);
}

TEST_CASE("tabulated values equal direct evaluations", "[rgl]") {
  Progress::set_enabled(false);
  for (const char* stem : kFiles) {
    INFO(stem);
    const std::string out = temp_path(std::string(stem) + "_small.h5");
    RglImportOptions opt;
    opt.file = rgl_path(stem);
    opt.n_theta_o = 12;
    opt.n_theta_i = 30;
    opt.n_phi_i = 60;
    opt.threads = 2;
    import_rgl_table(opt, out);
    TableReader r(out);
    const TableMeta& m = r.meta();
    REQUIRE(m.theta_o.size() == 12);
    RglBrdf b(opt.file);
    double max_rel = 0.0;
    for (std::size_t t = 0; t < m.theta_o.size(); t += 3) {
      const auto v = r.read_slice(t, 0);
      const auto c = r.read_slice_rgb(t, 0);
      for (std::size_t i = 0; i < m.theta_i.size(); i += 7)
        for (std::size_t p = 0; p < m.phi_i.size(); p += 11) {
          const RglValue d = b.eval(m.theta_o[t], 0.0, m.theta_i[i], m.phi_i[p]);
          const std::size_t k = i * m.phi_i.size() + p;
          const double scale = std::max(1e-6, std::abs(d.y));
          max_rel = std::max(max_rel, std::abs(double(v[k]) - d.y) / scale);
          for (int ch = 0; ch < 3; ++ch)
            max_rel = std::max(max_rel, std::abs(double(c[k * 3 + ch]) - d.rgb[ch]) / std::max(1e-6, std::abs(d.rgb[ch])));
        }
    }
    WARN(stem << ": max relative difference table vs direct " << max_rel);
    CHECK(max_rel < 1e-6);  // float32 storage
  }
}

TEST_CASE("malformed files are rejected with one line naming file and problem", "[rgl]") {
  const RglFile good(rgl_path("paper_white_rgb"));
  const auto& bytes = good.bytes();

  SECTION("bad magic") {
    auto b = bytes;
    b[0] = 'X';
    check_rejected(write_bytes("bad_magic.bsdf", b), "bad magic");
  }
  SECTION("unsupported version") {
    auto b = bytes;
    b[12] = 2;
    check_rejected(write_bytes("bad_version.bsdf", b), "unsupported tensor file version 2.0");
  }
  SECTION("truncated header") {
    check_rejected(write_bytes("trunc_header.bsdf", {bytes.begin(), bytes.begin() + 10}), "truncated header");
    check_rejected(write_bytes("trunc_count.bsdf", {bytes.begin(), bytes.begin() + 100}),
                   "truncated header (11 fields need at least");
    check_rejected(write_bytes("trunc_fields.bsdf", {bytes.begin(), bytes.begin() + 300}),
                   "truncated header of field");
  }
  SECTION("truncated data") {
    check_rejected(write_bytes("trunc_data.bsdf", {bytes.begin(), bytes.begin() + long(bytes.size() / 2)}),
                   "truncated data");
  }
  SECTION("empty file") { check_rejected(write_bytes("empty.bsdf", {}), "truncated header"); }
  SECTION("corrupt dimensions") {
    auto f = raw_fields(good);
    find(f, "vndf")->shape[1] = 7;  // 7 view elevations, theta_i has 8
    check_rejected(write_bytes("dims_vndf.bsdf", tensor_bytes(f)), "field 'vndf': wrong dimensions [1, 7, 128, 128]");
    auto g = raw_fields(good);
    find(g, "rgb")->shape = {1, 8, 32, 32};  // a channel axis missing
    check_rejected(write_bytes("dims_rgb.bsdf", tensor_bytes(g)), "field 'rgb': wrong dimensions");
    auto h = raw_fields(good);
    find(h, "sigma")->shape = {1ull << 40, 1ull << 40};  // absurd extents
    check_rejected(write_bytes("dims_huge.bsdf", tensor_bytes(h)), "field 'sigma': shape");
  }
  SECTION("wrong dtype") {
    auto f = raw_fields(good);
    find(f, "theta_i")->dtype = 11;  // float64 over 32 bytes of float32: 4 elements
    find(f, "theta_i")->shape = {4};
    check_rejected(write_bytes("dtype.bsdf", tensor_bytes(f)), "field 'theta_i': dtype float64, expected float32");
    auto g = raw_fields(good);
    find(g, "ndf")->dtype = 5;
    check_rejected(write_bytes("dtype_ndf.bsdf", tensor_bytes(g)), "field 'ndf': dtype uint32, expected float32");
  }
  SECTION("missing field") {
    for (const char* name : {"vndf", "rgb", "sigma", "theta_i", "jacobian"}) {
      auto f = raw_fields(good);
      f.erase(std::remove_if(f.begin(), f.end(), [&](const RawField& x) { return x.name == name; }), f.end());
      check_rejected(write_bytes(std::string("missing_") + name + ".bsdf", tensor_bytes(f)),
                     std::string("missing field '") + name + "'");
    }
  }
  SECTION("anisotropic data") {
    auto f = raw_fields(good);
    RawField* phi = find(f, "phi_i");
    phi->shape = {2};
    phi->data = float_bytes({0.0f, float(kPi)});
    check_rejected(write_bytes("aniso.bsdf", tensor_bytes(f)), "anisotropic data (field 'phi_i' has 2 values)");
  }
  SECTION("spectral data") {
    auto f = raw_fields(good);
    find(f, "rgb")->name = "spectra";
    check_rejected(write_bytes("spectral.bsdf", tensor_bytes(f)), "spectral data");
  }
  SECTION("float-rounding negatives read as 0 and are counted; real negatives are refused") {
    // The RGL database holds files whose luminance warp has values like -4e-10: within
    // float rounding of zero for a field of values up to ~1, which Mitsuba and pbrt load.
    auto set_float = [](RawField& f, std::size_t k, float v) {
      REQUIRE(4 * k + 4 <= f.data.size());
      std::memcpy(f.data.data() + 4 * k, &v, 4);
    };
    auto f = raw_fields(good);
    set_float(*find(f, "luminance"), 443, -4e-10f);
    set_float(*find(f, "luminance"), 2000, -1e-9f);
    set_float(*find(f, "vndf"), 17, -2e-10f);
    const std::string p = write_bytes("rounding_negatives.bsdf", tensor_bytes(f));
    const RglBrdf b(p);
    CHECK(b.rounding_zeros() == 3);
    CHECK(RglBrdf(rgl_path("paper_white_rgb")).rounding_zeros() == 0);
    auto g = raw_fields(good);
    set_float(*find(g, "luminance"), 443, -1e-3f);  // far beyond rounding: a real negative
    check_rejected(write_bytes("real_negative.bsdf", tensor_bytes(g)), "field 'luminance': element 443 is negative");
    // the import logs the count and writes a valid table
    RglImportOptions opt;
    opt.file = p;
    opt.n_theta_o = 4;
    opt.n_theta_i = 8;
    opt.n_phi_i = 16;
    const std::string table = temp_path("rounding_negatives.h5");
    import_rgl_table(opt, table);
    const TableReader r(table);
    for (std::size_t t = 0; t < 4; ++t) r.read_slice(t, 0);  // checks NaN, Inf, negative
  }
  SECTION("a rebuilt well-formed file is accepted and evaluates identically") {
    const std::string p = write_bytes("rebuilt.bsdf", tensor_bytes(raw_fields(good)));
    RglBrdf a(rgl_path("paper_white_rgb")), b(p);
    CHECK(a.eval(0.3, 0.0, 0.5, 1.0).y == b.eval(0.3, 0.0, 0.5, 1.0).y);
  }
}

TEST_CASE("the CLI imports a file and fails with one line on a bad one", "[rgl]") {
  const std::string out = temp_path("cli.h5"), err = temp_path("cli.err");
  std::string cmd = std::string(BSDFMIX_BINARY) + " import rgl " + rgl_path("paper_white_rgb") +
                    " --theta-o 6 --theta-i 10 --phi-i 20 --quiet -o " + out + " 2>" + err;
  REQUIRE(std::system(cmd.c_str()) == 0);
  TableReader r(out);
  CHECK(r.meta().theta_o.size() == 6);
  CHECK(r.meta().phi_i.size() == 20);

  auto b = RglFile(rgl_path("paper_white_rgb")).bytes();
  b[0] = 'X';
  const std::string bad = write_bytes("cli_bad.bsdf", b);
  cmd = std::string(BSDFMIX_BINARY) + " import rgl " + bad + " -o " + temp_path("cli_bad.h5") + " 2>" + err;
  CHECK(std::system(cmd.c_str()) != 0);
  std::ifstream in(err);
  std::string line, all;
  int lines = 0;
  while (std::getline(in, line)) ++lines, all += line;
  CHECK(lines == 1);
  CHECK_THAT(all, Contains("bad magic") && Contains("cli_bad.bsdf"));
  CHECK(!fs::exists(temp_path("cli_bad.h5")));
}

// A measurement (hidden: run it by its tag): the three files' albedo at every view degree
// from 0 to 75 and at 85, on the default grid (90 x 180 cells) and by importance sampling
// with the warps (64 x 64), and at 0, 45, 75 and 85 degrees by a converged midpoint rule
// (1440 x 2880 cells); the reciprocity's median, 90th percentile and f-weighted mean. With
// BSDFMIX_MEASURE_CSV set it writes the rows there (bench/reproduce.sh rgl_albedo;
// docs/rgl.md, "Measurements").
TEST_CASE("measure: albedo and reciprocity of the RGL files", "[.measure]") {
  std::ostringstream csv;
  csv << "file,quantity,theta_o_deg,value\n";
  csv.precision(6);
  for (const char* stem : kFiles) {
    const RglBrdf b(rgl_path(stem));
    std::vector<int> degrees;
    for (int d = 0; d <= 75; ++d) degrees.push_back(d);
    degrees.push_back(85);
    for (int d : degrees) {
      csv << stem << ",albedo_grid," << d << "," << albedo(b, deg(d), 90, 180) << "\n";
      csv << stem << ",albedo_sampled," << d << "," << albedo_is(b, deg(d), 64) << "\n";
      if (d == 0 || d == 45 || d == 75 || d == 85) {
        const double fine = albedo(b, deg(d), 1440, 2880);
        WARN(stem << " at " << d << " deg: converged albedo " << fine);
        csv << stem << ",albedo_fine," << d << "," << fine << "\n";
      }
    }
    const Reciprocity r = reciprocity(b);
    csv << stem << ",reciprocity_median,," << r.rel[r.rel.size() / 2] << "\n";
    csv << stem << ",reciprocity_p90,," << r.rel[r.rel.size() * 9 / 10] << "\n";
    csv << stem << ",reciprocity_weighted,," << r.weighted << "\n";
  }
  if (const char* path = std::getenv("BSDFMIX_MEASURE_CSV")) write_text_atomic(path, csv.str());
}

TEST_CASE("negative channels: kept signed, or clipped as Mitsuba and pbrt render them", "[rgl]") {
  Progress::set_enabled(false);
  // cg_sunflower: most of its cells hold a negative channel (docs/rgl.md)
  RglImportOptions opt;
  opt.file = rgl_path("cg_sunflower_rgb");
  opt.n_theta_o = 4;
  opt.n_theta_i = 16;
  opt.n_phi_i = 32;
  opt.threads = 2;
  const std::string kept = temp_path("sunflower_keep.h5"), clipped = temp_path("sunflower_clip.h5");
  import_rgl_table(opt, kept);
  opt.negative = RglNegative::Clip;
  import_rgl_table(opt, clipped);
  TableReader a(kept), b(clipped);
  CHECK(a.meta().source.find("negative") == std::string::npos);  // a kept table's source as always
  CHECK(b.meta().source.find("\"negative\": \"clip\"") != std::string::npos);
  std::size_t negative_cells = 0, cells = 0;
  for (std::size_t t = 0; t < a.meta().theta_o.size(); ++t) {
    const auto ya = a.read_slice(t, 0), yb = b.read_slice(t, 0);
    const auto ca = a.read_slice_rgb(t, 0), cb = b.read_slice_rgb(t, 0);
    for (std::size_t k = 0; k < ya.size(); ++k, ++cells) {
      bool negative = false;
      for (int ch = 0; ch < 3; ++ch) {
        negative = negative || ca[3 * k + ch] < 0.0f;
        CHECK(cb[3 * k + ch] == std::max(0.0f, ca[3 * k + ch]));
      }
      negative_cells += negative;
      const double y = rgb_luminance(cb[3 * k], cb[3 * k + 1], cb[3 * k + 2]);
      CHECK(std::abs(yb[k] - y) <= 1e-6 * std::max(1.0, y));
      if (negative) CHECK(yb[k] > ya[k]);  // clipping only adds light
      else CHECK(yb[k] == ya[k]);
    }
  }
  CHECK(negative_cells > cells / 2);
}

TEST_CASE("the file's own sampler passes a chi-square against its pdf, valid share included", "[rgl]") {
  // Samples binned in (cos theta_i, phi_i), against N times the pdf integrated over each bin
  // (a midpoint rule inside the bin, 8 x 8 points, then 64 x 64 where 16 x 16 differ from it
  // by more than a thousandth of a sample: cg_sunflower's peak is about a degree wide); the
  // samples the warps send below the horizon form one more bin, whose expectation is
  // N (1 - the pdf's integral over the hemisphere).
  constexpr int kZ = 16, kP = 32;
  constexpr std::size_t kN = 400000;
  for (const char* stem : kFiles) {
    RglBrdf b(rgl_path(stem));
    for (double to_deg : {17.0, 43.0, 71.0}) {
      const double to = deg(to_deg);
      const std::array<double, 3> wo = {std::sin(to), 0.0, std::cos(to)};
      std::vector<double> observed(kZ * kP + 1, 0.0), expected(kZ * kP + 1, 0.0);
      double integral = 0.0;
      auto bin_mass = [&](int iz, int ip, int sub) {
        double m = 0.0;
        for (int a = 0; a < sub; ++a)
          for (int c = 0; c < sub; ++c) {
            const double z = (iz + (a + 0.5) / sub) / kZ, p = -kPi + 2 * kPi * (ip + (c + 0.5) / sub) / kP;
            const double s = std::sqrt(std::max(0.0, 1 - z * z));
            m += b.pdf(wo, {s * std::cos(p), s * std::sin(p), z});
          }
        return m * (1.0 / kZ) * (2 * kPi / kP) / (sub * sub);  // d omega = dz dphi
      };
      for (int iz = 0; iz < kZ; ++iz)
        for (int ip = 0; ip < kP; ++ip) {
          double mass = bin_mass(iz, ip, 16);
          if (std::abs(mass - bin_mass(iz, ip, 8)) * kN > 1e-3 * std::max(1.0, mass * kN) ) mass = bin_mass(iz, ip, 64);
          expected[iz * kP + ip] = mass * kN;
          integral += mass;
        }
      expected[kZ * kP] = std::max(0.0, 1.0 - integral) * kN;
      std::mt19937_64 rng(11);
      std::uniform_real_distribution<double> U(0.0, 1.0);
      for (std::size_t k = 0; k < kN; ++k) {
        const auto smp = b.sample(wo, U(rng), U(rng));
        if (!smp.valid) {
          observed[kZ * kP] += 1;
          continue;
        }
        const double z = smp.omega_i[2], p = std::atan2(smp.omega_i[1], smp.omega_i[0]);
        const int iz = std::min(kZ - 1, int(z * kZ)), ip = std::min(kP - 1, int((p + kPi) / (2 * kPi) * kP));
        observed[iz * kP + ip] += 1;
      }
      const test::ChiSquare r = test::pearson(observed, expected);
      INFO(stem << " theta_o " << to_deg << ": chi-square " << r.stat << " on " << r.dof << " dof, p " << r.p
                << "; valid share " << 1 - observed[kZ * kP] / kN << ", pdf integral " << integral);
      std::printf("rgl_test: %s theta_o %2.0f: chi-square p %.3g, valid share %.5f, pdf integral %.5f\n", stem, to_deg,
                  r.p, 1 - observed[kZ * kP] / kN, integral);
      CHECK(r.p > 1e-3);
    }
  }
}

TEST_CASE("the narrowest lobe: its widths are where f cos falls to half, and the grid resolves it", "[rgl]") {
  const RglBrdf brdf(rgl_path("satin_rosaline_rgb"));
  const std::vector<RglLobe> lobes = rgl_lobes(brdf, 3);
  REQUIRE(lobes.size() == 3);
  for (const RglLobe& l : lobes) {
    INFO("theta_o " << l.theta_o << ": peak " << l.peak << " at (" << l.theta_i << ", " << l.phi_i << "), widths "
                    << l.fwhm_theta << " x " << l.fwhm_phi);
    REQUIRE(l.peak > 0);
    // a glossy lobe about the mirror direction (phi_i = pi: the view is at phi_o = 0)
    CHECK(std::abs(std::abs(l.phi_i) - kPi) < 0.05);
    CHECK(l.fwhm_theta > 0);
    CHECK(l.fwhm_phi > 0);
    CHECK(l.fwhm_theta < 2 * kLobeReach);
    // no direction on a fine ring around the peak beats it
    for (int k = 0; k < 16; ++k) {
      const double a = 2 * kPi * k / 16, r = 0.002;
      const double t = l.theta_i + r * std::cos(a), p = l.phi_i + r * std::sin(a) / std::sin(l.theta_i);
      CHECK(brdf.eval(l.theta_o, 0.0, t, p).y * std::cos(t) <= l.peak * 1.001);
    }
    // the theta width is the length of the line through the peak where f cos is at least
    // half the peak (the lobe is one interval on it)
    const double dt = 0.0005;
    double above = 0;
    for (double t = l.theta_i - kLobeReach; t <= l.theta_i + kLobeReach; t += dt)
      if (t > 0 && t < kPi / 2 && brdf.eval(l.theta_o, 0.0, t, l.phi_i).y * std::cos(t) >= 0.5 * l.peak) above += dt;
    CHECK(above == Approx(l.fwhm_theta).margin(3 * dt + 0.02 * l.fwhm_theta));
  }
  // the rule: 3 cells across every lobe, slices half a width apart, floors and caps kept
  RglLobe one;
  one.peak = 1;
  one.theta_o = one.theta_i = 1.2;
  one.fwhm_theta = kPi / 180;  // 1 degree
  one.fwhm_phi = 0.9 * kPi / 180;
  const RglGrid g = rgl_resolving_grid({one}, 90, 90, 180);
  CHECK(g.n_theta_i == 270);
  CHECK(g.n_theta_o == 180);
  CHECK(g.n_phi_i == std::size_t(std::ceil(3 * 360 / 0.9 * std::sin(1.2))));
  CHECK(g.narrowest.fwhm_phi == one.fwhm_phi);
  const RglGrid floors = rgl_resolving_grid({one}, 400, 400, 1500, 720, 1440);
  CHECK(floors.n_theta_i == 400);
  CHECK(floors.n_theta_o == 400);
  CHECK(floors.n_phi_i == 1500);
  one.fwhm_phi = 1e-4;
  CHECK(rgl_resolving_grid({one}, 90, 90, 180, 720, 1440).n_phi_i == 1440);
}
