// CPU references of kernels/sample.cl in double: sampling through the renderer-facing
// header (include/bsdfmix/mixture.hpp) and the six estimators of the convergence study.
#include <algorithm>
#include <cmath>

#include "sampling/sampling.hpp"

namespace bsdfmix {

std::vector<mix::Sample> sample_cpu(const mix::MixtureSet& set, double theta_o, double phi_o, std::uint64_t seed,
                                    std::uint32_t stream, std::uint64_t first, std::size_t n) {
  std::vector<mix::Sample> out(n);
  for (std::size_t i = 0; i < n; ++i) out[i] = set.sample_counter(theta_o, phi_o, seed, stream, first + i);
  return out;
}

void run_uniforms(std::uint64_t seed, std::uint32_t stream, std::uint32_t run, std::uint64_t n, double u[4]) {
  const std::uint32_t ctr[4] = {std::uint32_t(n), std::uint32_t(n >> 32), stream, run};
  const std::uint32_t key[2] = {std::uint32_t(seed), std::uint32_t(seed >> 32)};
  const mix::PhiloxBlock r = mix::philox4x32_10(ctr, key);
  for (int i = 0; i < 4; ++i) u[i] = mix::to_uniform(r.v[i]);
}

namespace {

// Uniform direction over the domain (pdf 1/(4 pi) fiber, 1/(2 pi) hemisphere).
void uniform_draw(Domain d, double u, double v, double& theta, double& phi) {
  theta = d == Domain::Hemisphere ? std::acos(1.0 - u) : std::asin(std::clamp(2 * u - 1, -1.0, 1.0));
  phi = 2 * kPi * v - kPi;
}

double uniform_pdf(Domain d) { return d == Domain::Hemisphere ? 1 / (2 * kPi) : 1 / (4 * kPi); }
double cos_factor(Domain d, double theta) { return d == Domain::Hemisphere ? std::cos(theta) : 1.0; }

// First i in [0, n) with cdf[i + 1] > u.
std::size_t cdf_find(const float* cdf, std::size_t n, double u) {
  std::size_t lo = 0, hi = n;
  while (lo < hi) {
    const std::size_t mid = (lo + hi) / 2;
    if (double(cdf[mid + 1]) > u) hi = mid;
    else lo = mid + 1;
  }
  return std::min(lo, n - 1);
}

}  // namespace

double estimate_cpu(const Problem& p, Estimator e, const double u[4]) {
  const mix::MixtureSet& set = *p.set;
  const Domain d = p.table.domain;
  const double to = p.theta_o, po = p.phi_o;
  switch (e) {
    case Estimator::UsTab:
    case Estimator::UsGmm: {
      double th, ph;
      uniform_draw(d, u[2], u[3], th, ph);
      const double f = e == Estimator::UsTab ? p.table.f_at(th, ph) : set.eval_f(to, po, th, ph);
      if (f == 0) return 0;
      return p.light.radiance(th, ph) * f * cos_factor(d, th) / uniform_pdf(d);
    }
    case Estimator::IsTab:
    case Estimator::IsGmm: {
      const mix::Sample s = set.sample(to, po, u[0], u[1], u[2], u[3]);
      if (!s.valid) return 0;
      const double f = e == Estimator::IsTab ? p.table.f_at(s.theta, s.phi) : set.eval_f(to, po, s.theta, s.phi);
      if (f == 0) return 0;
      return p.light.radiance(s.theta, s.phi) * f * cos_factor(d, s.theta) / s.pdf_omega;
    }
    case Estimator::MisTab: {
      const double a = p.uniform_fraction;
      double th, ph;
      if (u[0] < a) {
        uniform_draw(d, u[2], u[3], th, ph);
      } else {
        const mix::Sample s = set.sample(to, po, (u[0] - a) / (1 - a), u[1], u[2], u[3]);
        if (!(s.theta >= theta_min(d) && s.theta <= theta_max(d))) return 0;
        th = s.theta;
        ph = s.phi;
      }
      const double f = p.table.f_at(th, ph);
      if (f == 0) return 0;
      const double pdf = a * uniform_pdf(d) + (1 - a) * set.pdf_omega(to, po, th, ph);
      if (!(pdf > 0)) return 0;
      return p.light.radiance(th, ph) * f * cos_factor(d, th) / pdf;
    }
    case Estimator::CdfTab: {
      const TableSlice& t = p.table;
      const std::size_t i = cdf_find(p.cdf.marginal.data(), t.n_theta, u[0]);
      const float* row = &p.cdf.conditional[i * (t.n_phi + 1)];
      const std::size_t j = cdf_find(row, t.n_phi, u[1]);
      const double pc = double(p.cdf.marginal[i + 1] - p.cdf.marginal[i]) * double(row[j + 1] - row[j]);
      if (!(pc > 0)) return 0;
      const double a = t.theta_edge(i), b = t.theta_edge(i + 1);
      double th;
      if (d == Domain::Hemisphere) {
        const double sa = std::sin(a) * std::sin(a), sb = std::sin(b) * std::sin(b);
        th = std::asin(std::sqrt(std::clamp(sa + u[2] * (sb - sa), 0.0, 1.0)));
      } else {
        const double sa = std::sin(a), sb = std::sin(b);
        th = std::asin(std::clamp(sa + u[2] * (sb - sa), -1.0, 1.0));
      }
      const double ph = wrap_phi(t.ph0 + t.dph * (double(j) + u[3]) + t.rotate);
      return p.light.radiance(th, ph) * double(t.f[i * t.n_phi + j]) * t.cell_weight(i) / pc;
    }
  }
  return 0;
}

RunSums integrate_cpu(const Problem& p, Estimator e, int runs, std::uint64_t n_max, std::uint64_t seed) {
  RunSums rs;
  rs.runs = runs;
  rs.levels = 1;
  while ((std::uint64_t(1) << (rs.levels - 1)) < n_max) ++rs.levels;
  rs.sum.assign(std::size_t(runs) * std::size_t(rs.levels), 0.0);
  const std::uint32_t stream = estimator_stream(int(e));
  for (int r = 0; r < runs; ++r) {
    double s = 0;
    int level = 0;
    std::uint64_t next = 1;
    for (std::uint64_t n = 0; n < n_max; ++n) {
      double u[4];
      run_uniforms(seed, stream, std::uint32_t(r), n, u);
      s += estimate_cpu(p, e, u);
      if (n + 1 == next) {
        rs.sum[std::size_t(r) * std::size_t(rs.levels) + std::size_t(level++)] = s;
        next <<= 1;
      }
    }
  }
  return rs;
}

}  // namespace bsdfmix
