// The narrowest lobe of an RGL BRDF and the grid that resolves it (tables/rgl_lobe.hpp).
#include "tables/rgl_lobe.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <thread>

#include "tables/rgl_brdf.hpp"

namespace bsdfmix {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180;

double f_cos(const RglBrdf& b, double theta_o, double theta_i, double phi_i) {
  if (!(theta_i > 0 && theta_i < kPi / 2)) return 0;
  return b.eval(theta_o, 0.0, theta_i, phi_i).y * std::cos(theta_i);
}

// The distance from the peak (at 0) to where g falls to half of g(0), stepping by `step`
// up to kLobeReach, linear between the last two steps; kLobeReach when it never does.
template <class G>
double half_reach(const G& g, double peak, double step) {
  double prev = peak;
  for (double x = step; x <= kLobeReach; x += step) {
    const double v = g(x);
    if (v <= 0.5 * peak) return x - step + step * (prev - 0.5 * peak) / std::max(prev - v, 1e-300);
    prev = v;
  }
  return kLobeReach;
}

RglLobe lobe_at(const RglBrdf& b, double theta_o) {
  RglLobe l;
  l.theta_o = theta_o;
  for (int i = 0; i < 180; ++i)
    for (int j = 0; j < 360; ++j) {
      const double t = (i + 0.5) * 0.5 * kDeg, p = -kPi + (j + 0.5) * kDeg;
      const double v = f_cos(b, theta_o, t, p);
      if (v > l.peak) l = {theta_o, t, p, v, 0, 0};
    }
  // polish the peak on a finer grid around it
  const RglLobe coarse = l;
  for (int i = -25; i <= 25; ++i)
    for (int j = -50; j <= 50; ++j) {
      const double t = coarse.theta_i + i * 0.02 * kDeg, p = coarse.phi_i + j * 0.02 * kDeg;
      const double v = f_cos(b, theta_o, t, p);
      if (v > l.peak) l = {theta_o, t, p, v, 0, 0};
    }
  if (!(l.peak > 0)) {
    l.fwhm_theta = l.fwhm_phi = 2 * kLobeReach;
    return l;
  }
  const double step = 0.01 * kDeg;
  auto along_t = [&](double s) { return [&, s](double x) { return f_cos(b, theta_o, l.theta_i + s * x, l.phi_i); }; };
  // across: the great circle through the peak along the azimuthal direction there,
  // d(x) = cos(x) p + sin(x) e_phi
  const double st = std::sin(l.theta_i), ct = std::cos(l.theta_i), cp = std::cos(l.phi_i), sp = std::sin(l.phi_i);
  const double p[3] = {st * cp, st * sp, ct}, e[3] = {-sp, cp, 0.0};
  const std::array<double, 3> wo = {std::sin(theta_o), 0.0, std::cos(theta_o)};
  auto along_p = [&](double s) {
    return [&, s](double x) {
      const double c = std::cos(s * x), n = std::sin(s * x);
      const std::array<double, 3> d = {c * p[0] + n * e[0], c * p[1] + n * e[1], c * p[2] + n * e[2]};
      return d[2] > 0 ? b.eval(wo, d).y * d[2] : 0.0;
    };
  };
  l.fwhm_theta = half_reach(along_t(1), l.peak, step) + half_reach(along_t(-1), l.peak, step);
  l.fwhm_phi = half_reach(along_p(1), l.peak, step) + half_reach(along_p(-1), l.peak, step);
  return l;
}

}  // namespace

std::vector<RglLobe> rgl_lobes(const RglBrdf& brdf, int views) {
  std::vector<RglLobe> out(std::size_t(std::max(views, 1)));
  std::atomic<std::size_t> next{0};
  auto work = [&] {
    for (std::size_t k; (k = next++) < out.size();) out[k] = lobe_at(brdf, (double(k) + 0.5) * (kPi / 2) / double(out.size()));
  };
  std::vector<std::thread> pool;
  const unsigned n = std::max(1u, std::min(std::thread::hardware_concurrency(), unsigned(out.size())));
  for (unsigned t = 1; t < n; ++t) pool.emplace_back(work);
  work();
  for (auto& t : pool) t.join();
  return out;
}

RglGrid rgl_resolving_grid(const std::vector<RglLobe>& lobes, std::size_t floor_theta_o, std::size_t floor_theta_i,
                           std::size_t floor_phi_i, std::size_t cap_theta, std::size_t cap_phi) {
  RglGrid g;
  g.n_theta_o = floor_theta_o;
  g.n_theta_i = floor_theta_i;
  g.n_phi_i = floor_phi_i;
  double narrowest = 1e300;
  for (const RglLobe& l : lobes) {
    if (!(l.peak > 0)) continue;
    const double w = std::min(l.fwhm_theta, l.fwhm_phi);
    if (w < narrowest) {
      narrowest = w;
      g.narrowest = l;
    }
    // theta_i cells of (pi/2) / n: kCellsPerLobe across fwhm_theta; phi_i cells of arc
    // sin(theta_i) 2 pi / n: kCellsPerLobe across fwhm_phi
    const auto n_t = std::size_t(std::ceil(kCellsPerLobe * (kPi / 2) / l.fwhm_theta));
    const auto n_p = std::size_t(std::ceil(kCellsPerLobe * 2 * kPi * std::sin(l.theta_i) / l.fwhm_phi));
    const auto n_o = std::size_t(std::ceil(2 * (kPi / 2) / l.fwhm_theta));
    g.n_theta_i = std::max(g.n_theta_i, std::min(n_t, cap_theta));
    g.n_phi_i = std::max(g.n_phi_i, std::min(n_p, cap_phi));
    g.n_theta_o = std::max(g.n_theta_o, std::min(n_o, cap_theta));
  }
  return g;
}

}  // namespace bsdfmix
