// kernels/common.cl, the primitives every kernel program shares, on the device: its
// Philox4x32-10 draws what the header's (bsdfmix::mix::philox4x32_10) and Random123's
// draw; its phi wrap agrees with the header's within float rounding; its lane sums are
// the tree of halves. Each through a small kernel built by the program layer
// (build_program_text puts common.cl in front, as for every kernel file).
#include <catch2/catch.hpp>

#include <Random123/philox.h>

#include <algorithm>
#include <bsdfmix/mixture.hpp>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "core/error.hpp"
#include "device/device.hpp"
#include "device/program.hpp"

using namespace bsdfmix;

namespace {

const char* const kProbe = R"CL(
__kernel void philox(__global const uint4* ctr, __global const uint2* key, const uint n, __global uint4* out) {
  const uint i = get_global_id(0);
  if (i < n) out[i] = philox4x32_10(ctr[i], key[i]);
}

__kernel void wrap(__global const float* x, const uint n, __global float* out) {
  const uint i = get_global_id(0);
  if (i < n) out[i] = wrap_phi(x[i]);
}

__kernel void lanes(__global const float16* v, const uint n, __global float4* out) {
  const uint i = get_global_id(0);
  if (i < n) out[i] = (float4)(sum_lanes16(v[i]), sum_lanes8(v[i].lo), sum_lanes4(v[i].lo.lo), sum_lanes2(v[i].lo.lo.lo));
}
)CL";

// Runs kernel `name` of kProbe over n items: `in` (and `in2`, when not empty) in, `out_bytes` out.
template <typename Out>
std::vector<Out> run_probe(const char* name, std::size_t n, const void* in, std::size_t in_bytes, const void* in2,
                           std::size_t in2_bytes) {
  const Device dev = select_devices("0").front();
  const cl::Program program = build_program_text(dev, "rng_test", kProbe);
  cl::Kernel k(program, name);
  cl::Buffer a(dev.context(), CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, in_bytes, const_cast<void*>(in));
  cl::Buffer out(dev.context(), CL_MEM_WRITE_ONLY, n * sizeof(Out));
  int arg = 0;
  k.setArg(arg++, a);
  cl::Buffer b;
  if (in2) {
    b = cl::Buffer(dev.context(), CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, in2_bytes, const_cast<void*>(in2));
    k.setArg(arg++, b);
  }
  k.setArg(arg++, cl_uint(n));
  k.setArg(arg++, out);
  cl::CommandQueue q = dev.make_queue();
  launch(q, k, name, cl::NDRange(n));
  std::vector<Out> r(n);
  q.enqueueReadBuffer(out, CL_TRUE, 0, n * sizeof(Out), r.data());
  return r;
}

float next_up(float x, int ulps) {
  for (int i = 0; i < ulps; ++i) x = std::nextafter(x, std::numeric_limits<float>::infinity());
  return x;
}
float next_down(float x, int ulps) {
  for (int i = 0; i < ulps; ++i) x = std::nextafter(x, -std::numeric_limits<float>::infinity());
  return x;
}

}  // namespace

TEST_CASE("common.cl's Philox4x32-10 draws what the header's and Random123's draw", "[rng][device]") {
  const std::uint32_t words[] = {0u, 1u, 2u, 0x12345678u, 0x66696265u, 0x7fffffffu, 0x80000000u, 0xdeadbeefu,
                                 0xfffffffeu, 0xffffffffu};
  const std::uint32_t keys[][2] = {{0, 0}, {1, 0}, {0, 1}, {0xdeadbeefu, 0xcafef00du}, {0xffffffffu, 0xffffffffu},
                                   {20240611u, 0}};
  std::vector<cl_uint4> ctr(1, cl_uint4{{0, 0, 0, 0}});  // first: Random123's known answer below
  std::vector<cl_uint2> key(1, cl_uint2{{0, 0}});
  const std::size_t nw = sizeof words / sizeof words[0];
  for (std::size_t i = 0; i < nw; ++i)
    for (std::size_t j = 0; j < 8; ++j)
      for (const auto& k : keys) {
        // counters mixing the words in every position, as the kernels' {index lo, index hi, stream, run}
        cl_uint4 c;
        c.s[0] = words[i];
        c.s[1] = words[(i + j) % nw];
        c.s[2] = words[(i + 2 * j + 1) % nw];
        c.s[3] = words[(3 * i + j) % nw];
        cl_uint2 kk;
        kk.s[0] = k[0];
        kk.s[1] = k[1];
        ctr.push_back(c);
        key.push_back(kk);
      }
  const std::size_t n = ctr.size();
  const auto dev = run_probe<cl_uint4>("philox", n, ctr.data(), n * sizeof(cl_uint4), key.data(), n * sizeof(cl_uint2));
  r123::Philox4x32 rng;
  std::size_t same = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint32_t c[4] = {ctr[i].s[0], ctr[i].s[1], ctr[i].s[2], ctr[i].s[3]};
    const std::uint32_t k[2] = {key[i].s[0], key[i].s[1]};
    const mix::PhiloxBlock header = mix::philox4x32_10(c, k);
    const auto ref = rng({{c[0], c[1], c[2], c[3]}}, {{k[0], k[1]}});
    bool all = true;
    for (int w = 0; w < 4; ++w) {
      INFO("counter " << c[0] << " " << c[1] << " " << c[2] << " " << c[3] << ", key " << k[0] << " " << k[1]
                      << ", word " << w);
      CHECK(header.v[w] == ref.v[w]);
      CHECK(dev[i].s[w] == ref.v[w]);
      all = all && header.v[w] == ref.v[w] && dev[i].s[w] == ref.v[w];
    }
    same += all;
  }
  CHECK(same == n);
  // Random123's known answer (kat_vectors, philox4x32 10 rounds, counter and key zero)
  const std::uint32_t kat[4] = {0x6627e8d5u, 0xe169c58du, 0xbc57ac4cu, 0x9b00dbd8u};
  for (int w = 0; w < 4; ++w) CHECK(dev[0].s[w] == kat[w]);
}

TEST_CASE("common.cl's wrap_phi agrees with the header's within float rounding", "[rng][device]") {
  const float pi = float(mix::kPi);
  std::vector<float> x = {0.0f, -0.0f, pi, -pi, 2 * pi, -2 * pi, 3 * pi, -3 * pi, 1e-30f, -1e-30f};
  // around every multiple of pi up to +-7 pi (the reach of the fiber kernel's arguments), a few ulps each side
  for (int m = -7; m <= 7; ++m) {
    const float c = float(m * mix::kPi);
    for (int u = 0; u <= 4; ++u) {
      x.push_back(next_up(c, u));
      x.push_back(next_down(c, u));
    }
  }
  for (int i = 0; i <= 20000; ++i) x.push_back(float(-25.0 + 50.0 * i / 20000.0));
  const std::size_t n = x.size();
  const auto dev = run_probe<float>("wrap", n, x.data(), n * sizeof(float), nullptr, 0);
  double worst = 0, below = 0;
  for (std::size_t i = 0; i < n; ++i) {
    INFO("phi " << x[i] << " -> " << dev[i]);
    // in [-pi, pi); beyond 3 pi the float multiple of 2 pi taken off can round past -pi by an ulp or so
    CHECK(dev[i] < pi);
    if (std::abs(x[i]) < 3 * pi) CHECK(dev[i] >= -pi);
    else CHECK(dev[i] >= next_down(-pi, 4));
    if (dev[i] < -pi) below = std::max(below, double(-pi) - double(dev[i]));
    // the same angle as the header's double wrap: a difference of a few float roundings of
    // |phi| + pi, measured around the circle (either side of the seam at -+pi)
    const double host = mix::wrap_phi(double(x[i]));
    const double d = std::remainder(double(dev[i]) - host, 2 * mix::kPi);
    const double ulp = std::ldexp(1.0, std::ilogb(std::abs(x[i]) + pi) - 23);
    worst = std::max(worst, std::abs(d) / ulp);
    CHECK(std::abs(d) <= 4 * ulp);
    if (std::abs(x[i]) < pi) CHECK(dev[i] == x[i]);  // inside: untouched
  }
  INFO("largest difference from the header: " << worst << " ulp of |phi| + pi; farthest below -pi: " << below);
  CHECK(worst <= 4);
}

TEST_CASE("common.cl's lane sums add halves until two lanes are left", "[rng][device]") {
  const std::size_t n = 64;
  std::vector<cl_float16> v(n);
  for (std::size_t i = 0; i < n; ++i)
    for (int l = 0; l < 16; ++l) v[i].s[l] = float(std::ldexp(1.0 + 0.37 * l, int(l) - 8 + int(i % 7))) * (l % 3 ? 1 : -1);
  const auto dev = run_probe<cl_float4>("lanes", n, v.data(), n * sizeof(cl_float16), nullptr, 0);
  for (std::size_t i = 0; i < n; ++i) {
    float a[16];
    for (int l = 0; l < 16; ++l) a[l] = v[i].s[l];
    // the tree in float: lanes l and l + w/2 added, w = 16, 8, 4, 2
    auto tree = [&](int w) {
      float t[16];
      for (int l = 0; l < w; ++l) t[l] = a[l];
      for (; w > 1; w /= 2)
        for (int l = 0; l < w / 2; ++l) t[l] = t[l] + t[l + w / 2];
      return t[0];
    };
    CHECK(dev[i].s[0] == tree(16));
    CHECK(dev[i].s[1] == tree(8));
    CHECK(dev[i].s[2] == tree(4));
    CHECK(dev[i].s[3] == tree(2));
  }
}

TEST_CASE("common.cl is no program of its own", "[rng][device]") {
  CHECK_FALSE(kernel_file("common").empty());
  CHECK_THROWS_WITH(kernel_source("common"), Catch::Contains("not built on its own"));
  const std::string em = kernel_source("em");
  CHECK(em.find("uint4 philox4x32_10(") != std::string::npos);
  CHECK(em.find("#line 1 \"em.cl\"") != std::string::npos);
  CHECK(em.find("#line 1 \"fit_common.cl\"") != std::string::npos);
  CHECK_THROWS_WITH(kernel_source("fit_common"), Catch::Contains("not built on its own"));
}
