// The cost of mis_product's product at one path vertex, one thread: the header's path
// (carry_lighting into a SliceMixture, mix::product, which allocates, sorts every pair
// and prepares every kept component) against the renderer's (render/fast_product.hpp:
// reused float buffers, vectorized pair weights, pruning by mass before the sort). Each
// vertex builds the product of the lighting carried into a random surface frame with the
// slice nearest a random theta_o, draws one sample and evaluates the density twice (the
// light sample's and an escaped ray's), as the integrator does.
//
//   build/bench/bsdfmix_bench_product_vertex MIXTURE.h5 LIGHT_MIXTURE.h5 [--vertices N]
//
// e.g. after `bsdfmix render configs/render/satin_skymap.yaml`, with MIXTURE.h5
// out/render_satin/satin_mixture.h5 and LIGHT_MIXTURE.h5
// out/render_satin/skymap/light_mixtures/light_skymap_*.h5;
// prints the nanoseconds per vertex of each path (best of 3 runs) and their mean
// component counts.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "io/mixture_file.hpp"
#include "render/fast_product.hpp"
#include "render/light_carry.hpp"

using namespace bsdfmix;
using namespace bsdfmix::render;

namespace {

struct Vertex {
  LocalAxes axes;
  std::size_t slice;
  double u[4], theta, phi;
};

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: %s MIXTURE.h5 LIGHT_MIXTURE.h5 [--vertices N]\n", argv[0]);
    return 2;
  }
  std::size_t n = 20000;
  for (int i = 3; i + 1 < argc; ++i)
    if (std::string(argv[i]) == "--vertices") n = std::size_t(std::atol(argv[i + 1]));
  try {
    const mix::MixtureSet set = to_mixture_set(read_mixture_file(argv[1]));
    const mix::MixtureSet light = to_mixture_set(read_mixture_file(argv[2]));
    const std::vector<mix::Gaussian> compact = compact_components(light.slices.at(0));
    std::printf("product_vertex: %zu slices (K %zu..%zu), lighting K %zu (%zu compact)\n", set.slices.size(),
                std::min_element(set.slices.begin(), set.slices.end(), [](auto& a, auto& b) { return a.components.size() < b.components.size(); })->components.size(),
                std::max_element(set.slices.begin(), set.slices.end(), [](auto& a, auto& b) { return a.components.size() < b.components.size(); })->components.size(),
                light.slices[0].components.size(), compact.size());
    // random vertices: the normal uniform on the sphere, phi = 0 along a random tangent
    std::vector<Vertex> vs(n);
    for (std::size_t i = 0; i < n; ++i) {
      double u[4];
      mix::uniforms(7, 1, std::uint32_t(i), u);
      const double z = 2 * u[0] - 1, a = 2 * kPi * u[1], r = std::sqrt(std::max(0.0, 1 - z * z));
      Vertex& v = vs[i];
      v.axes.domain = Domain::Hemisphere;
      v.axes.axis = {r * std::cos(a), r * std::sin(a), z};
      const Vec3 any = std::abs(z) < 0.9 ? Vec3{0, 0, 1} : Vec3{1, 0, 0};
      const Vec3 p = normalized(cross(v.axes.axis, any)), q = cross(v.axes.axis, p);
      for (int k = 0; k < 3; ++k) v.axes.e1[k] = std::cos(u[2] * 2 * kPi) * p[k] + std::sin(u[2] * 2 * kPi) * q[k];
      v.axes.e2 = cross(v.axes.axis, v.axes.e1);
      const double theta_o = 1.4 * u[3];
      v.slice = 0;
      for (std::size_t s = 1; s < set.slices.size(); ++s)
        if (std::abs(set.slices[s].theta_o - theta_o) < std::abs(set.slices[v.slice].theta_o - theta_o)) v.slice = s;
      mix::uniforms(7, 2, std::uint32_t(i), v.u);
      v.theta = 0.5 * kPi * v.u[3];
      v.phi = kPi * (2 * v.u[2] - 1);
    }
    const mix::ProductOptions o{0.99, 32};
    double sink = 0;
    std::size_t comps_header = 0, comps_fast = 0;
    auto time = [&](auto&& body) {
      double best = 1e300;
      for (int run = 0; run < 3; ++run) {
        const auto t0 = std::chrono::steady_clock::now();
        body();
        best = std::min(best, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
      }
      return best * 1e9 / double(n);
    };
    const double header_ns = time([&] {
      comps_header = 0;
      for (const Vertex& v : vs) {
        try {
          const mix::SliceMixture m = mix::product(set.slices[v.slice], 0.0, carry_lighting(compact, v.axes, kWorldAxes, set.map), o);
          comps_header += m.components.size();
          const mix::Sample s = m.sample(Domain::Hemisphere, v.u[0], v.u[1], v.u[2]);
          sink += s.pdf_omega + m.pdf_omega(Domain::Hemisphere, v.theta, v.phi);
        } catch (const std::invalid_argument&) {
        }
      }
    });
    std::vector<ProductFactor> factors(set.slices.size());
    for (std::size_t s = 0; s < set.slices.size(); ++s) factors[s].assign(set.slices[s]);
    const CarrySource source(compact);
    FastProduct fp;
    const double fast_ns = time([&] {
      comps_fast = 0;
      for (const Vertex& v : vs) {
        if (!fp.build(factors[v.slice], source, v.axes, o)) continue;
        comps_fast += fp.size();
        const mix::Sample s = fp.sample(Domain::Hemisphere, v.u[0], v.u[1], v.u[2]);
        sink += s.pdf_omega + fp.pdf_omega(Domain::Hemisphere, v.theta, v.phi);
      }
    });
    std::printf("product_vertex: %zu vertices, one thread: header product %.0f ns per vertex (%.2f components), "
                "per-vertex product %.0f ns (%.2f components), %.1fx faster (checksum %.3g)\n",
                n, header_ns, double(comps_header) / double(n), fast_ns, double(comps_fast) / double(n),
                header_ns / fast_ns, sink);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "product_vertex: %s\n", e.what());
    return 1;
  }
  return 0;
}
