// The draws and densities the study's estimators combine.
#include "sampling/draws.hpp"

#include <array>
#include <stdexcept>

#include "tables/rgl_brdf.hpp"

namespace bsdfmix {
namespace draws {

bool cdf_draw(const Problem& p, double u0, double u1, double u2, double u3, double& th, double& ph) {
  const TableSlice& t = p.table;
  const std::size_t i = cdf_find(p.cdf.marginal.data(), t.n_theta, u0);
  const float* row = &p.cdf.conditional[i * (t.n_phi + 1)];
  const std::size_t j = cdf_find(row, t.n_phi, u1);
  if (!(row[j + 1] - row[j] > 0) || !(p.cdf.marginal[i + 1] - p.cdf.marginal[i] > 0)) return false;
  const double a = t.theta_edge(i), b = t.theta_edge(i + 1);
  if (t.domain == Domain::Hemisphere) {
    const double sa = std::sin(a) * std::sin(a), sb = std::sin(b) * std::sin(b);
    th = std::asin(std::sqrt(std::clamp(sa + u2 * (sb - sa), 0.0, 1.0)));
  } else {
    const double sa = std::sin(a), sb = std::sin(b);
    th = std::asin(std::clamp(sa + u2 * (sb - sa), -1.0, 1.0));
  }
  ph = wrap_phi(t.ph0 + t.dph * (double(j) + u3) + t.rotate);
  return true;
}

double cdf_pdf(const Problem& p, double th, double ph) {
  const TableSlice& t = p.table;
  const double fi = std::floor((th - t.th0) / t.dth);
  if (!inside(t.domain, th) || !(fi >= 0) || fi >= double(t.n_theta)) return 0;
  const std::size_t i = std::size_t(fi);
  long j = long(std::floor((wrap_phi(ph - t.rotate) - t.ph0) / t.dph)) % long(t.n_phi);
  if (j < 0) j += long(t.n_phi);
  const float* row = &p.cdf.conditional[i * (t.n_phi + 1)];
  const double pc = double(p.cdf.marginal[i + 1] - p.cdf.marginal[i]) * double(row[j + 1] - row[j]);
  const double w = t.cell_weight(i);
  return w > 0 ? pc * cos_factor(t.domain, th) / w : 0;
}

double light_pdf(const Problem& p, double th, double ph) {
  return inside(p.table.domain, th) ? p.light_sampler.pdf(p.light.to_world(th, ph)) : 0.0;
}

void light_draw(const Problem& p, double u0, double u1, double u2, double u3, double& th, double& ph) {
  world_to_slice(p.light, p.light_sampler.sample(u0, u1, u2, u3), th, ph);
}

namespace {

const RglBrdf& rgl_of(const Problem& p) {
  if (!p.rgl) throw std::invalid_argument("the RGL file's warps: the problem has no RGL file (Problem::rgl)");
  return *p.rgl;
}

std::array<double, 3> rgl_view(const Problem& p) { return {std::sin(p.theta_o), 0.0, std::cos(p.theta_o)}; }

// One-sample MIS weight: techniques with fractions c[k] and densities pdf[k] at the point,
// the point drawn by technique `chosen`. Balance: 1 / sum c p; power (beta 2): c_s p_s / sum (c p)^2.
double mis_weight(const double* c, const double* pdf, int n, int chosen, bool power) {
  double s1 = 0, s2 = 0;
  for (int k = 0; k < n; ++k) {
    s1 += c[k] * pdf[k];
    s2 += (c[k] * pdf[k]) * (c[k] * pdf[k]);
  }
  if (!(s1 > 0)) return 0;
  return power ? c[chosen] * pdf[chosen] / s2 : 1 / s1;
}

}  // namespace

bool rgl_draw(const Problem& p, double u1, double u2, double& th, double& ph, double* pdf) {
  const RglBrdf::Sample s = rgl_of(p).sample(rgl_view(p), u1, u2);
  if (!s.valid) return false;
  th = std::acos(std::clamp(s.omega_i[2], -1.0, 1.0));
  ph = wrap_phi(std::atan2(s.omega_i[1], s.omega_i[0]) + p.table.rotate);
  if (pdf) *pdf = s.pdf;
  return inside(p.table.domain, th);
}

double rgl_pdf(const Problem& p, double th, double ph) {
  if (!inside(p.table.domain, th)) return 0;
  const double pl = wrap_phi(ph - p.table.rotate), st = std::sin(th);
  return rgl_of(p).pdf(rgl_view(p), {st * std::cos(pl), st * std::sin(pl), std::cos(th)});
}

double uniform_estimate(const Problem& p, const double u[4], FOf f_of) {
  const Domain d = p.table.domain;
  double th, ph;
  uniform_draw(d, u[2], u[3], th, ph);
  const double f = f_of(p, th, ph);
  if (f == 0) return 0;
  return p.light.radiance(th, ph) * f * cos_factor(d, th) / uniform_pdf(d);
}

double uniform_density(const Problem& p, double, double) { return uniform_pdf(p.table.domain); }

bool uniform_direction(const Problem& p, const double u[4], double& th, double& ph) {
  uniform_draw(p.table.domain, u[2], u[3], th, ph);
  return true;
}

double mixture_estimate(const Problem& p, const double u[4], FOf f_of) {
  const mix::Sample s = p.set->sample(p.theta_o, p.phi_o, u[0], u[1], u[2], u[3]);
  if (!s.valid) return 0;
  const double f = f_of(p, s.theta, s.phi);
  if (f == 0) return 0;
  return p.light.radiance(s.theta, s.phi) * f * cos_factor(p.table.domain, s.theta) / s.pdf_omega;
}

double mixture_density(const Problem& p, double th, double ph) { return p.set->pdf_omega(p.theta_o, p.phi_o, th, ph); }

bool mixture_direction(const Problem& p, const double u[4], double& th, double& ph) {
  const mix::Sample s = p.set->sample(p.theta_o, p.phi_o, u[0], u[1], u[2], u[3]);
  th = s.theta;
  ph = s.phi;
  return s.valid;
}

const Technique kLightTechnique = {
    [](const Problem& p, double r0, const double u[4], double& th, double& ph) {
      light_draw(p, r0, u[1], u[2], u[3], th, ph);
      return true;
    },
    light_pdf};
const Technique kUniformTechnique = {
    [](const Problem& p, double, const double u[4], double& th, double& ph) {
      uniform_draw(p.table.domain, u[2], u[3], th, ph);
      return true;
    },
    [](const Problem& p, double th, double) { return inside(p.table.domain, th) ? uniform_pdf(p.table.domain) : 0; }};
const Technique kCdfTechnique = {
    [](const Problem& p, double r0, const double u[4], double& th, double& ph) {
      return cdf_draw(p, r0, u[1], u[2], u[3], th, ph);
    },
    cdf_pdf};
const Technique kMixtureTechnique = {
    [](const Problem& p, double r0, const double u[4], double& th, double& ph) {
      const mix::Sample s = p.set->sample(p.theta_o, p.phi_o, r0, u[1], u[2], u[3]);
      th = s.theta;
      ph = s.phi;
      return true;
    },
    [](const Problem& p, double th, double ph) {
      return inside(p.table.domain, th) ? p.set->pdf_omega(p.theta_o, p.phi_o, th, ph) : 0;
    }};
const Technique kProductTechnique = {
    [](const Problem& p, double, const double u[4], double& th, double& ph) {
      const mix::Sample s = p.product.sample(p.table.domain, u[1], u[2], u[3]);
      th = s.theta;
      ph = s.phi;
      return true;
    },
    [](const Problem& p, double th, double ph) {
      return inside(p.table.domain, th) ? p.product.pdf_omega(p.table.domain, th, ph) : 0;
    }};
const Technique kRglTechnique = {
    [](const Problem& p, double, const double u[4], double& th, double& ph) { return rgl_draw(p, u[1], u[2], th, ph); },
    rgl_pdf};

double mis_estimate(const Problem& p, const MisTechniques& t, const double u[4]) {
  const Domain d = p.table.domain;
  int k = 0;
  double lo = 0;
  while (k + 1 < t.n && u[0] >= lo + t.c[k]) lo += t.c[k++];
  const double r0 = std::clamp((u[0] - lo) / t.c[k], 0.0, 1.0 - 1e-17);
  double th = 0, ph = 0, pdf[3];
  if (!t.t[k]->draw(p, r0, u, th, ph)) return 0;
  if (!inside(d, th)) return 0;
  const double f = p.table.f_at(th, ph);
  if (f == 0) return 0;
  for (int j = 0; j < t.n; ++j) pdf[j] = t.t[j]->pdf(p, th, ph);
  const double w = mis_weight(t.c, pdf, t.n, k, p.mis.power);
  return w > 0 ? p.light.radiance(th, ph) * f * cos_factor(d, th) * w : 0;
}

double mis_pdf(const Problem& p, const MisTechniques& t, double th, double ph) {
  double pdf[3];
  for (int k = 0; k < t.n; ++k) pdf[k] = t.t[k]->pdf(p, th, ph);
  double s = 0;
  for (int k = 0; k < t.n; ++k) s += t.c[k] * pdf[k];
  return s;
}

}  // namespace draws
}  // namespace bsdfmix
