// The shared host primitives: the grid bracket of the header, the number formatter,
// SplitMix64, the vector operations, the PFM codec (its checks, each error one line
// naming the file) and the header's slice mixture from parameter arrays. kernels/common.cl has its own test, tests/rng_test.cpp.
#include <catch2/catch.hpp>

#include <bsdfmix/mixture.hpp>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include "core/domain.hpp"
#include "core/error.hpp"
#include "core/format.hpp"
#include "core/hash.hpp"
#include "core/vec3.hpp"
#include "io/pfm.hpp"

using namespace bsdfmix;
namespace fs = std::filesystem;

namespace {

std::string temp_path(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / "bsdfmix_primitives_test";
  fs::create_directories(dir);
  return (dir / name).string();
}

void spit(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
}

std::string le(const std::vector<float>& v) {
  std::string s;
  for (float f : v) {
    std::uint32_t u;
    std::memcpy(&u, &f, 4);
    for (int k = 0; k < 4; ++k) s.push_back(char((u >> (8 * k)) & 0xff));
  }
  return s;
}

std::string error_of(const std::string& path) {
  try {
    read_pfm(path);
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

}  // namespace

TEST_CASE("bracket: the two cells around a value, clamped or periodic", "[primitives]") {
  // centers 0.5, 1.5, 2.5, 3.5
  const std::vector<double> axis = {0.5, 1.5, 2.5, 3.5};
  Bracket b = bracket(axis, 1.75, false);
  CHECK(b.i0 == 1);
  CHECK(b.i1 == 2);
  CHECK(b.f == Approx(0.25));
  b = bracket(axis, 0.1, false);  // before the first center: held
  CHECK((b.i0 == 0 && b.i1 == 0 && b.f == 0));
  b = bracket(axis, 9.0, false);  // past the last
  CHECK((b.i0 == 3 && b.i1 == 3 && b.f == 0));
  b = bracket(axis, 2.5, false);  // on a center: that cell, weight 0
  CHECK((b.i0 == 2 && b.f == 0));
  b = bracket(axis, 3.75, true);  // periodic: between the last and the first
  CHECK((b.i0 == 3 && b.i1 == 0));
  CHECK(b.f == Approx(0.25));
  b = bracket(axis, 0.25 - 4.0, true);  // a period below
  CHECK((b.i0 == 3 && b.i1 == 0));
  CHECK(b.f == Approx(0.75));
  b = bracket(std::vector<double>{1.0}, 7.0, true);  // one cell
  CHECK((b.i0 == 0 && b.i1 == 0 && b.f == 0));
  // first/step form: the same numbers
  const Bracket c = bracket(0.5, 1.0, 4, 1.75, false);
  CHECK((c.i0 == 1 && c.i1 == 2 && c.f == bracket(axis, 1.75, false).f));
}

TEST_CASE("format_number: printf for finite values, words for the others", "[primitives]") {
  CHECK(format_number(0.1, "%.9g") == "0.1");
  CHECK(format_number(1.0 / 3.0, "%.9g") == "0.333333333");
  CHECK(format_number(123456789.0, "%g") == "1.23457e+08");
  CHECK(format_number(2.5, "%.3f") == "2.500");
  const double inf = std::numeric_limits<double>::infinity(), nan = std::numeric_limits<double>::quiet_NaN();
  CHECK(format_number(inf, "%.9g") == "inf");
  CHECK(format_number(-inf, "%.3g") == "-inf");
  CHECK(format_number(nan, "%.9g") == "nan");
  CHECK(format_number(-nan, "%.9g") == "nan");
}

TEST_CASE("splitmix64 is SplitMix64", "[primitives]") {
  // the first outputs of SplitMix64 seeded with 0 (state advanced, then mixed)
  CHECK(splitmix64(0) == 0xE220A8397B1DCDAFull);
  CHECK(splitmix64(0x9E3779B97F4A7C15ull) == 0x6E789E6AA1B965F4ull);
}

TEST_CASE("Vec3 operations", "[primitives]") {
  const Vec3 a{1, 2, 3}, b{-2, 0.5, 4};
  CHECK(dot(a, b) == 11);
  CHECK(cross(a, b) == Vec3{6.5, -10, 4.5});
  CHECK(sub(a, b) == Vec3{3, 1.5, -1});
  CHECK(neg(a) == Vec3{-1, -2, -3});
  CHECK(normalized(Vec3{3, 0, 4}) == Vec3{0.6, 0, 0.8});
  CHECK(normalized(Vec3{0, 0, 0}) == Vec3{0, 0, 0});
}

TEST_CASE("PFM: grey and RGB read as luminance, row 0 at the top", "[primitives][pfm]") {
  PfmImage img;
  img.width = 3;
  img.height = 2;
  img.luminance = {0.f, 1.f, 2.f, 3.f, 4.f, std::numeric_limits<float>::max()};
  const std::string p = temp_path("round.pfm");
  write_pfm(p, img);
  const PfmImage back = read_pfm(p);
  CHECK(back.width == 3);
  CHECK(back.height == 2);
  CHECK(back.luminance == img.luminance);
  // RGB, big endian (positive scale): file rows bottom to top
  std::string bytes = "PF\n1 2\n1.0\n";
  for (float f : {1.f, 0.f, 0.f, 2.f, 2.f, 2.f}) {
    std::uint32_t u;
    std::memcpy(&u, &f, 4);
    for (int k = 3; k >= 0; --k) bytes.push_back(char((u >> (8 * k)) & 0xff));
  }
  spit(p, bytes);
  const PfmImage rgb = read_pfm(p);
  CHECK(rgb.luminance[0] == 2.f);  // R = G = B: exact
  CHECK(rgb.luminance[1] == Approx(0.2126f));
}

TEST_CASE("PFM: every bad file is rejected in one line naming it and the problem", "[primitives][pfm]") {
  const std::string p = temp_path("bad.pfm");
  struct Case {
    std::string bytes, what;
  };
  const std::vector<Case> cases = {
      {"P6\n1 1\n255\n", "not a PFM"},
      {"Pf\n0 1\n-1.0\n" + le({1}), "width 0 out of range"},
      {"Pf\n65537 1\n-1.0\n" + le({1}), "width 65537 out of range"},
      {"Pf\n2 x\n-1.0\n" + le({1, 1}), "bad PFM height 'x'"},
      {"Pf\n1 +1\n-1.0\n" + le({1}), "bad PFM height '+1'"},
      {"Pf\n65536 65536\n-1.0\n", "too large"},
      {"Pf\n1 1\n0\n" + le({1}), "bad PFM scale '0'"},
      {"Pf\n1 1\ninf\n" + le({1}), "bad PFM scale 'inf'"},
      {"Pf\n1 1\n-1.0x\n" + le({1}), "bad PFM scale '-1.0x'"},
      {"Pf\n1 1", "truncated header"},
      {"Pf\n2 1\n-1.0\n" + le({1}), "truncated"},
      {"Pf\n1 1\n-1.0\n" + le({1, 1}), "trailing bytes"},
      {"Pf\n2 1\n-1.0\n" + le({1, -1}), "pixel (1, 0) is negative or not finite"},
      {"Pf\n1 1\n-1.0\n" + le({std::numeric_limits<float>::quiet_NaN()}), "pixel (0, 0) is negative or not finite"},
      {"PF\n1 1\n-1.0\n" + le({1, std::numeric_limits<float>::infinity(), 1}), "negative or not finite"},
  };
  for (const auto& c : cases) {
    spit(p, c.bytes);
    const std::string msg = error_of(p);
    INFO(c.what << ": " << msg);
    CHECK(msg.rfind(p + ": ", 0) == 0);
    CHECK_THAT(msg, Catch::Contains(c.what));
    CHECK(msg.find('\n') == std::string::npos);
  }
  const std::string missing = temp_path("missing.pfm");
  fs::remove(missing);
  CHECK_THROWS_AS(read_pfm(missing), IoError);
  CHECK_THAT(error_of(missing), Catch::StartsWith(missing + ": cannot open"));
}

TEST_CASE("PFM: the writer checks the image and writes into an existing directory only", "[primitives][pfm]") {
  PfmImage img;
  img.width = 2;
  img.height = 2;
  img.luminance = {1, 2, 3};
  CHECK_THROWS_AS(write_pfm(temp_path("short.pfm"), img), InputError);
  img.width = 0;
  img.luminance.clear();
  CHECK_THROWS_AS(write_pfm(temp_path("empty.pfm"), img), InputError);
  img.width = 1;
  img.height = 1;
  img.luminance = {1};
  const std::string nowhere = temp_path("no_such_dir") + "/a.pfm";
  fs::remove_all(temp_path("no_such_dir"));
  CHECK_THROWS_AS(write_pfm(nowhere, img), IoError);
  CHECK_FALSE(fs::exists(temp_path("no_such_dir")));
}

TEST_CASE("the header builds a slice mixture from parameter arrays", "[primitives][header]") {
  // two components as a mixture file stores them (float), with colour
  const float w[2] = {3.f, 1.f}, mean[4] = {0.1f, -0.5f, 0.4f, 2.f}, cov[6] = {0.02f, 0.001f, 0.05f, 0.03f, 0.f, 0.1f};
  const double rgb[6] = {0.5, 0.25, 0.125, 1, 2, 3};
  mix::SliceMixture s = mix::slice_from_arrays(2, w, mean, cov, rgb);
  REQUIRE(s.components.size() == 2);
  CHECK(s.has_rgb);
  CHECK(s.components[1].weight == 1.0);  // not prepared: as given
  CHECK(s.components[1].mu_t == double(0.4f));
  CHECK(s.components[1].mu_p == 2.0);
  CHECK(s.components[0].s_tp == double(0.001f));
  CHECK(s.components[1].s_pp == double(0.1f));
  CHECK(s.components[1].rgb[2] == 3.0);
  CHECK(s.cdf.empty());
  CHECK_FALSE(mix::slice_from_arrays(2, w, mean, cov).has_rgb);

  const mix::SliceMixture p = mix::make_slice_mixture({3.0, 1.0}, {0.1, -0.5, 0.4, 2.0}, {0.02, 0.001, 0.05, 0.03, 0, 0.1});
  CHECK(p.components[0].weight == 0.75);  // prepared: weights normalized
  CHECK(p.cdf.size() == 2);
  CHECK_FALSE(p.has_rgb);
  CHECK_THROWS_AS(mix::make_slice_mixture({1.0}, {0.1}, {0.02, 0, 0.05}), std::invalid_argument);
}
