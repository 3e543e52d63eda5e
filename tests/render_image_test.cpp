// Images of `bsdfmix render` (host/render/image_io.cpp): bit-exact EXR and PFM round trips
// of non-square images with 0, tiny and huge values; the PFM's row order and bytes; no
// temporary left behind; the IoError/InputError of a missing directory and of garbage
// files, naming the path; RGB and Y EXRs of other writers read as luminance; and
// relative_mse against its formula.
// labels: render
#include <catch2/catch.hpp>

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfOutputFile.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <limits>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "render/image_io.hpp"

using namespace bsdfmix;
using namespace bsdfmix::render;
namespace fs = std::filesystem;

namespace {

std::string temp_path(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / "bsdfmix_render_image_test";
  fs::create_directories(dir);
  return (dir / name).string();
}

// A w x h image holding 0, the smallest denormal, FLT_MIN, 1e6, FLT_MAX, negative zero
// and a pseudo-random spread of magnitudes; every pixel distinct from its neighbours.
Image test_image(int w, int h) {
  Image im(w, h);
  const float special[] = {0.f,
                           std::numeric_limits<float>::denorm_min(),
                           std::numeric_limits<float>::min(),
                           1e-30f,
                           1e6f,
                           std::numeric_limits<float>::max(),
                           -0.f,
                           0.1f};
  std::uint32_t s = 12345;
  for (std::size_t i = 0; i < im.v.size(); ++i) {
    if (i < std::size(special)) {
      im.v[i] = special[i];
      continue;
    }
    s = s * 1664525u + 1013904223u;
    const float mant = float(s >> 8) / float(1u << 24);
    const int e = int((s >> 3) % 40) - 20;
    im.v[i] = std::ldexp(mant, e);
  }
  return im;
}

bool bit_equal(const Image& a, const Image& b) {
  return a.width == b.width && a.height == b.height && a.v.size() == b.v.size() &&
         std::memcmp(a.v.data(), b.v.data(), a.v.size() * sizeof(float)) == 0;
}

std::string slurp(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
}

void spit(const std::string& path, const std::string& bytes) {
  std::ofstream f(path, std::ios::binary | std::ios::trunc);
  f << bytes;
}

std::vector<std::string> partial_files(const std::string& dir) {
  std::vector<std::string> out;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().filename().string().find(".partial-") != std::string::npos) out.push_back(e.path().string());
  return out;
}

// The what() of the Error thrown by f, or "(no error)".
std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

// An EXR with float channels named `names`, each filled by `value(channel, x, y)`.
void write_channels(const std::string& path, int w, int h, const std::vector<std::string>& names,
                    const std::function<float(std::size_t, int, int)>& value) {
  Imf::Header header(w, h);
  std::vector<std::vector<float>> data(names.size(), std::vector<float>(std::size_t(w) * std::size_t(h)));
  Imf::FrameBuffer fb;
  for (std::size_t c = 0; c < names.size(); ++c) {
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) data[c][std::size_t(y) * std::size_t(w) + std::size_t(x)] = value(c, x, y);
    header.channels().insert(names[c], Imf::Channel(Imf::FLOAT));
    fb.insert(names[c], Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(data[c].data()), sizeof(float),
                                   sizeof(float) * std::size_t(w)));
  }
  Imf::OutputFile out(path.c_str(), header);
  out.setFrameBuffer(fb);
  out.writePixels(h);
}

}  // namespace

TEST_CASE("EXR round trips are bit-exact for non-square images", "[render][image]") {
  for (auto [w, h] : {std::pair{7, 3}, std::pair{3, 11}, std::pair{1, 1}, std::pair{64, 17}}) {
    const Image im = test_image(w, h);
    const std::string p = temp_path("round_" + std::to_string(w) + "x" + std::to_string(h) + ".exr");
    write_exr(p, im);
    const Image back = read_exr(p);
    CHECK(back.width == w);
    CHECK(back.height == h);
    CHECK(bit_equal(back, im));
  }
}

TEST_CASE("PFM round trips are bit-exact for non-square images", "[render][image]") {
  for (auto [w, h] : {std::pair{7, 3}, std::pair{3, 11}, std::pair{1, 1}, std::pair{64, 17}}) {
    const Image im = test_image(w, h);
    const std::string p = temp_path("round_" + std::to_string(w) + "x" + std::to_string(h) + ".pfm");
    write_pfm(p, im);
    const Image back = read_pfm_image(p);
    CHECK(back.width == w);
    CHECK(back.height == h);
    CHECK(bit_equal(back, im));
  }
}

TEST_CASE("the PFM stores the bottom row first, little endian, R G B interleaved", "[render][image]") {
  Image im(5, 3);
  for (int y = 0; y < 3; ++y)
    for (int x = 0; x < 5; ++x)
      for (int c = 0; c < 3; ++c) im.at(x, y, c) = float(100 * c + 10 * y + x) + 0.5f;
  const std::string p = temp_path("rows.pfm");
  write_pfm(p, im);
  const std::string bytes = slurp(p);
  const std::string header = "PF\n5 3\n-1.0\n";
  REQUIRE(bytes.size() == header.size() + 5 * 3 * 3 * 4);
  CHECK(bytes.substr(0, header.size()) == header);
  for (int row = 0; row < 3; ++row) {
    const int y = 2 - row;  // stored row 0 is image row height-1
    for (int x = 0; x < 5; ++x)
      for (int c = 0; c < 3; ++c) {
        const std::size_t at = header.size() + (std::size_t(row * 5 + x) * 3 + std::size_t(c)) * 4;
        std::uint32_t u = 0;
        for (int k = 0; k < 4; ++k)
          u |= std::uint32_t(static_cast<unsigned char>(bytes[at + std::size_t(k)])) << (8 * k);
        float f;
        std::memcpy(&f, &u, 4);
        CHECK(f == im.at(x, y, c));
      }
  }
}

TEST_CASE("a grey Pf file reads as R = G = B", "[render][image]") {
  std::string bytes = "Pf\n2 1\n-1.0\n";
  for (float f : {0.25f, 3.f}) {
    std::uint32_t u;
    std::memcpy(&u, &f, 4);
    for (int k = 0; k < 4; ++k) bytes.push_back(char((u >> (8 * k)) & 0xff));
  }
  const std::string p = temp_path("grey.pfm");
  spit(p, bytes);
  const Image im = read_pfm_image(p);
  REQUIRE(im.width == 2);
  for (int c = 0; c < 3; ++c) {
    CHECK(im.at(0, 0, c) == 0.25f);
    CHECK(im.at(1, 0, c) == 3.f);
  }
}

TEST_CASE("a 3-channel PF file reads its channels", "[render][image]") {
  // 2x1, big endian (positive scale): (1, 1, 1) and (1, 0, 0).
  std::string bytes = "PF\n2 1\n1.0\n";
  auto put_be = [&](float f) {
    std::uint32_t u;
    std::memcpy(&u, &f, 4);
    for (int k = 3; k >= 0; --k) bytes.push_back(char((u >> (8 * k)) & 0xff));
  };
  for (float f : {1.f, 1.f, 1.f, 1.f, 0.f, 0.f}) put_be(f);
  const std::string p = temp_path("rgb.pfm");
  spit(p, bytes);
  const Image im = read_pfm_image(p);
  REQUIRE(im.width == 2);
  REQUIRE(im.height == 1);
  for (int c = 0; c < 3; ++c) CHECK(im.at(0, 0, c) == 1.f);
  CHECK(im.at(1, 0, 0) == 1.f);
  CHECK(im.at(1, 0, 1) == 0.f);
  CHECK(im.at(1, 0, 2) == 0.f);
}

TEST_CASE("EXRs of other writers read as RGB, or Y as grey", "[render][image]") {
  const std::string rgb = temp_path("other_rgb.exr"), y = temp_path("other_y.exr"), a = temp_path("other_a.exr");
  write_channels(rgb, 4, 2, {"B", "G", "R"},
                 [](std::size_t c, int x, int) { return c == 0 ? 1.f : c == 1 ? 2.f : float(x); });
  const Image im = read_exr(rgb);
  REQUIRE(im.width == 4);
  REQUIRE(im.height == 2);
  for (int x = 0; x < 4; ++x) {
    CHECK(im.at(x, 1, 0) == float(x));
    CHECK(im.at(x, 1, 1) == 2.f);
    CHECK(im.at(x, 1, 2) == 1.f);
  }
  write_channels(y, 3, 5, {"Y"}, [](std::size_t, int x, int yy) { return float(x + 10 * yy); });
  const Image iy = read_exr(y);
  REQUIRE(iy.width == 3);
  REQUIRE(iy.height == 5);
  for (int c = 0; c < 3; ++c) CHECK(iy.at(2, 4, c) == 42.f);
  write_channels(a, 2, 2, {"A"}, [](std::size_t, int, int) { return 1.f; });
  const std::string msg = error_of([&] { read_exr(a); });
  CHECK_THAT(msg, Catch::Contains(a) && Catch::Contains("channels"));
}

TEST_CASE("writing leaves no temporary file and replaces an existing image", "[render][image]") {
  const fs::path dir = fs::path(temp_path("atomic"));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const Image a = test_image(6, 4), b = test_image(2, 9);
  write_exr((dir / "x.exr").string(), a);
  write_pfm((dir / "x.pfm").string(), a);
  write_exr((dir / "x.exr").string(), b);
  write_pfm((dir / "x.pfm").string(), b);
  CHECK(partial_files(dir.string()).empty());
  CHECK(bit_equal(read_exr((dir / "x.exr").string()), b));
  CHECK(bit_equal(read_pfm_image((dir / "x.pfm").string()), b));
  std::size_t n = 0;
  for (const auto& e : fs::directory_iterator(dir)) n += e.is_regular_file() ? 1 : 0;
  CHECK(n == 2);
}

TEST_CASE("writing into a missing directory throws IoError naming the path", "[render][image]") {
  const std::string dir = temp_path("no_such_dir");
  fs::remove_all(dir);
  const Image im = test_image(3, 2);
  for (const std::string name : {"/a.exr", "/a.pfm"}) {
    const std::string p = dir + name;
    std::string msg;
    try {
      if (name == "/a.exr")
        write_exr(p, im);
      else
        write_pfm(p, im);
      msg = "(no error)";
    } catch (const IoError& e) {
      msg = e.what();
    }
    CHECK_THAT(msg, Catch::Contains(p));
    CHECK_FALSE(fs::exists(dir));
  }
}

TEST_CASE("reading garbage, truncated or missing files throws naming the path", "[render][image]") {
  const std::string garbage_exr = temp_path("garbage.exr"), garbage_pfm = temp_path("garbage.pfm");
  spit(garbage_exr, "this is not an OpenEXR file at all, just some text\n");
  spit(garbage_pfm, "P6\n3 2\n255\nxxxxxxxxxxxxxxxxxx");
  CHECK_THAT(error_of([&] { read_exr(garbage_exr); }), Catch::Contains(garbage_exr));
  CHECK_THAT(error_of([&] { read_pfm_image(garbage_pfm); }), Catch::Contains(garbage_pfm));
  CHECK_THAT(error_of([&] { read_pfm_image(garbage_exr); }), Catch::Contains(garbage_exr));
  CHECK_THAT(error_of([&] { read_exr(garbage_pfm); }), Catch::Contains(garbage_pfm));

  // A truncated EXR and a truncated PFM.
  const Image im = test_image(16, 8);
  const std::string full_exr = temp_path("full.exr"), cut_exr = temp_path("cut.exr");
  const std::string full_pfm = temp_path("full.pfm"), cut_pfm = temp_path("cut.pfm");
  write_exr(full_exr, im);
  write_pfm(full_pfm, im);
  const std::string e = slurp(full_exr), f = slurp(full_pfm);
  spit(cut_exr, e.substr(0, e.size() / 2));
  spit(cut_pfm, f.substr(0, f.size() - 3));
  CHECK_THAT(error_of([&] { read_exr(cut_exr); }), Catch::Contains(cut_exr));
  CHECK_THAT(error_of([&] { read_pfm_image(cut_pfm); }), Catch::Contains(cut_pfm) && Catch::Contains("truncated"));

  // PFM headers with bad sizes or scale, and trailing bytes.
  const std::string bad = temp_path("bad.pfm");
  for (const std::string head : {"Pf\n0 3\n-1.0\n", "Pf\n-2 3\n-1.0\n", "Pf\n2 x\n-1.0\n", "Pf\n2 3\n0\n",
                                 "Pf\n2 3\nabc\n", "Pf\n99999999999 3\n-1.0\n", "Pf\n2"}) {
    spit(bad, head + std::string(24, '\0'));
    CHECK_THAT(error_of([&] { read_pfm_image(bad); }), Catch::Contains(bad));
  }
  spit(bad, "Pf\n1 1\n-1.0\n" + std::string(5, '\0'));
  CHECK_THAT(error_of([&] { read_pfm_image(bad); }), Catch::Contains(bad) && Catch::Contains("trailing"));

  const std::string missing = temp_path("missing.exr");
  fs::remove(missing);
  std::string msg;
  try {
    read_exr(missing);
  } catch (const IoError& ex) {
    msg = ex.what();
  }
  CHECK_THAT(msg, Catch::Contains(missing));
  msg.clear();
  try {
    read_pfm_image(missing);
  } catch (const IoError& ex) {
    msg = ex.what();
  }
  CHECK_THAT(msg, Catch::Contains(missing));
}

TEST_CASE("relative_mse follows its formula", "[render][image]") {
  Image ref(4, 3);
  for (int y = 0; y < 3; ++y)
    for (int x = 0; x < 4; ++x)
      for (int c = 0; c < 3; ++c) ref.at(x, y, c) = 0.1f + float(x * y) + 0.5f * float(c);
  ref.set_grey(0, 0, 0.f);  // a dark pixel: eps keeps it finite
  CHECK(relative_mse(ref, ref) == 0.0);

  Image twice = ref;
  for (float& v : twice.v) v *= 2.f;
  double mean = 0;
  for (float v : ref.v) mean += v;
  mean /= double(ref.v.size());
  const double eps = 1e-2 * mean * mean;
  double expect = 0;
  for (float r : ref.v) expect += double(r) * double(r) / (double(r) * double(r) + eps);
  expect /= double(ref.v.size());
  const double got = relative_mse(twice, ref);
  CHECK(got == Approx(expect).epsilon(1e-12));
  CHECK(got < 1.0);

  // Without dark pixels, 2x the reference is off by about 100%: r^2 / (r^2 + eps) ~ 1.
  Image bright(5, 2), bright2(5, 2);
  for (std::size_t i = 0; i < bright.v.size(); ++i) {
    bright.v[i] = 1.f + 0.1f * float(i);
    bright2.v[i] = 2.f * bright.v[i];
  }
  CHECK(relative_mse(bright2, bright) == Approx(1.0).epsilon(0.02));
  CHECK(relative_mse(bright2, bright) < 1.0);

  // An all-zero reference: no NaN for equal pixels.
  Image zero(2, 2), one(2, 2);
  one.v.assign(12, 1.f);
  CHECK(relative_mse(zero, zero) == 0.0);
  CHECK(std::isinf(relative_mse(one, zero)));

  Image other(3, 4);
  CHECK_THROWS_AS(relative_mse(other, ref), InputError);
  CHECK_THROWS_AS(relative_mse(Image(4, 2), ref), InputError);

  // A mask: the mean over its pixels only, eps still from every value.
  Image off = ref;
  off.at(1, 2, 0) += 1.f;  // one value off, in a masked pixel
  off.at(3, 0, 2) += 5.f;  // and one outside the mask
  std::vector<std::uint8_t> mask(12, 0);
  mask[2 * 4 + 1] = mask[2 * 4 + 2] = 1;
  const double r = ref.at(1, 2, 0);
  CHECK(relative_mse(off, ref, &mask) == Approx(1.0 / (r * r + eps) / 6.0).epsilon(1e-6));
  const std::vector<std::uint8_t> none(12, 0);
  CHECK(relative_mse(off, ref, &none) == -1.0);
  const std::vector<std::uint8_t> short_mask(11, 1);
  CHECK_THROWS_AS(relative_mse(off, ref, &short_mask), InputError);
}
