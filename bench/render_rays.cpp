// Primary-ray throughput of the renderer's tracer (host/render/tracer.cpp) for each curve
// type, on one thread: a cloth of 20000 fibers of 16 segments, seen from a pinhole camera
// above it at 512 x 512 (one ray per pixel centre), best of 3 runs per curve type.
//
//   build-bench/bench/bsdfmix_bench_render_rays [--csv PATH] [--runs N]
//
// writes bench/results/render_rays_<machine>.csv (relative to the working directory) with
// machine,curve_type,fibers,segments,rays,seconds,rays_per_second,hit_fraction; the
// machine is /proc/cpuinfo's "model name" shortened (amd-epyc) and the logical CPUs
// (amd-epyc-2c). Only the intersect calls are timed; scene builds are not.
#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <string>
#include <vector>

#include "bench/machine_peak.hpp"
#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "render/cloth.hpp"
#include "render/tracer.hpp"

using namespace bsdfmix;
using namespace bsdfmix::render;

namespace {

// "AMD EPYC 7B13 64-Core Processor" -> "amd-epyc": the first two words, lower case,
// without (R)/(TM) marks.
std::string short_model(std::string m) {
  for (const char* mark : {"(R)", "(r)", "(TM)", "(tm)"})
    for (std::size_t at; (at = m.find(mark)) != std::string::npos;) m.erase(at, std::string(mark).size());
  std::istringstream words(m);
  std::string w, out;
  for (int k = 0; k < 2 && words >> w; ++k) out += (out.empty() ? "" : "-") + w;
  for (char& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out.empty() ? "unknown" : out;
}

// The cloth: 8 yarns each way (spacing 1/8 on a unit patch) of 2 plies of 625 fibers is
// 2 x 8 x 2 x 625 = 20000 fibers; 2 segments per spacing over 8 spacings is 16 segments.
// One ply and one fiber turn per unit length: 16 segments per turn, so the coarse
// polylines (and B-splines on them) still follow the helices.
ClothParams bench_cloth() {
  ClothParams p;
  p.size = 1.0;
  p.yarn_spacing = 0.125;
  p.yarn_radius = 0.05;
  p.plies = 2;
  p.fibers_per_ply = 625;
  p.ply_twist = 1;
  p.fiber_twist = 1;
  p.fiber_radius = 0.0008;
  p.segments_per_spacing = 2;
  p.seed = 1;
  return p;
}

// Pinhole camera at (0, -0.4, 1.4) looking at the origin, 40 degrees vertical field of
// view, square image: one ray through each pixel centre.
std::vector<Ray> camera_rays(int w, int h) {
  const double eye[3] = {0, -0.4, 1.4};
  double f[3] = {-eye[0], -eye[1], -eye[2]};
  const double fn = std::sqrt(f[0] * f[0] + f[1] * f[1] + f[2] * f[2]);
  for (double& c : f) c /= fn;
  // right = f x (0, 0, 1) normalised, up = right x f.
  double rt[3] = {f[1], -f[0], 0};
  const double rn = std::sqrt(rt[0] * rt[0] + rt[1] * rt[1]);
  for (double& c : rt) c /= rn;
  const double up[3] = {rt[1] * f[2] - rt[2] * f[1], rt[2] * f[0] - rt[0] * f[2], rt[0] * f[1] - rt[1] * f[0]};
  const double tan_half = std::tan(20.0 * 3.14159265358979323846 / 180);
  std::vector<Ray> rays(static_cast<std::size_t>(w) * h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const double sx = (2 * (x + 0.5) / w - 1) * tan_half, sy = (1 - 2 * (y + 0.5) / h) * tan_half;
      Ray& r = rays[static_cast<std::size_t>(y) * w + x];
      double d[3];
      for (int c = 0; c < 3; ++c) d[c] = f[c] + sx * rt[c] + sy * up[c];
      const double dn = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
      r.org = {eye[0], eye[1], eye[2]};
      r.dir = {d[0] / dn, d[1] / dn, d[2] / dn};
    }
  return rays;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    const std::string machine = short_model(bench::cpu_model_name()) + "-" + std::to_string(bench::logical_cpus()) + "c";
    std::string csv = "bench/results/render_rays_" + machine + ".csv";
    int runs = 3;
    for (int i = 1; i < argc; ++i) {
      const std::string a = argv[i];
      if (a == "--csv" && i + 1 < argc) csv = argv[++i];
      else if (a == "--runs" && i + 1 < argc) runs = std::max(1, std::atoi(argv[++i]));
      else throw ConfigError("render_rays: unknown argument '" + a + "' (expected --csv PATH, --runs N)");
    }
    prepare_output(csv);

    const Cloth cloth = make_cloth(bench_cloth(), "render_rays");
    const std::vector<Ray> rays = camera_rays(512, 512);
    std::printf("machine %s, %zu fibers, %zu segments, %zu rays, best of %d, load average %.2f\n", machine.c_str(),
                cloth.fibers.size(), cloth.segments(), rays.size(), runs, bench::load_average_1min());

    const std::pair<CurveType, const char*> types[] = {{CurveType::FlatLinear, "flat_linear"},
                                                       {CurveType::RoundLinear, "round_linear"},
                                                       {CurveType::FlatBSpline, "flat_bspline"},
                                                       {CurveType::RoundBSpline, "round_bspline"}};
    std::ostringstream out;
    out << "machine,curve_type,fibers,segments,rays,seconds,rays_per_second,hit_fraction\n";
    for (const auto& [type, name] : types) {
      const auto b0 = std::chrono::steady_clock::now();
      const Tracer tracer(cloth, GroundPlane{}, type);
      const double build = std::chrono::duration<double>(std::chrono::steady_clock::now() - b0).count();
      double best = 1e300;
      std::size_t hits = 0;
      for (int run = 0; run < runs; ++run) {
        std::size_t n = 0;
        const auto t0 = std::chrono::steady_clock::now();
        for (const Ray& r : rays) n += tracer.intersect(r).kind == HitKind::Fiber;
        best = std::min(best, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
        hits = n;
      }
      const double hit_fraction = static_cast<double>(hits) / rays.size();
      std::printf("%-14s %10.4f s  %12.0f rays/s  hits %.4f  (scene build %.2f s, not timed)\n", name, best,
                  rays.size() / best, hit_fraction, build);
      out << machine << ',' << name << ',' << cloth.fibers.size() << ',' << cloth.segments() << ',' << rays.size()
          << ',' << best << ',' << rays.size() / best << ',' << hit_fraction << '\n';
    }
    write_text_atomic(csv, out.str());
    std::printf("wrote %s\n", csv.c_str());
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "render_rays: %s\n", e.what());
    return 1;
  }
}
