// CPU references of kernels/sample.cl in double: sampling through the renderer-facing
// header (include/bsdfmix/mixture.hpp) and the estimators of the convergence study (is_rgl
// and mis_light_rgl, the RGL file's own warps, exist here alone).
#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>
#include <string>

#include "sampling/sampling.hpp"
#include "tables/rgl_brdf.hpp"

namespace bsdfmix {

std::vector<mix::Sample> sample_cpu(const mix::MixtureSet& set, double theta_o, double phi_o, std::uint64_t seed,
                                    std::uint32_t stream, std::uint64_t first, std::size_t n) {
  std::vector<mix::Sample> out(n);
  for (std::size_t i = 0; i < n; ++i) out[i] = set.sample_counter(theta_o, phi_o, seed, stream, first + i);
  return out;
}

std::size_t cdf_find(const float* cdf, std::size_t n, double u) {
  std::size_t lo = 0, hi = n;
  while (lo < hi) {
    const std::size_t mid = (lo + hi) / 2;
    if (double(cdf[mid + 1]) > u) hi = mid;
    else lo = mid + 1;
  }
  return std::min(lo, n - 1);
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

bool inside(Domain d, double theta) { return theta >= theta_lo(d) && theta <= theta_hi(d); }

// The table CDF's draw: cell by the 2D CDF, theta inside it with density c J, phi uniform.
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

// Its density per steradian: P_cell c(theta) / integral over the cell of c J.
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

// The RGL file's warps in the table's frame: the view omega_o at phi = 0 of the slice
// frame (where the importer puts it), the light direction rotated into the world frame by
// the table's rotation (phi_o under azimuthal symmetry), as TableSlice::f_at reads it.
const RglBrdf& rgl_of(const Problem& p) {
  if (!p.rgl) throw std::invalid_argument("is_rgl, mis_light_rgl: the problem has no RGL file (Problem::rgl)");
  return *p.rgl;
}

std::array<double, 3> rgl_view(const Problem& p) { return {std::sin(p.theta_o), 0.0, std::cos(p.theta_o)}; }

// Draws with u1, u2 (the file's two uniforms); false below the horizon.
bool rgl_draw(const Problem& p, double u1, double u2, double& th, double& ph, double* pdf = nullptr) {
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

// One-sample MIS: techniques with fractions c[k] and densities pdf[k] at the point, the
// point drawn by technique `chosen`. Balance: 1 / sum c p; power (beta 2): c_s p_s / sum (c p)^2.
double mis_weight(const double* c, const double* pdf, int n, int chosen, bool power) {
  double s1 = 0, s2 = 0;
  for (int k = 0; k < n; ++k) {
    s1 += c[k] * pdf[k];
    s2 += (c[k] * pdf[k]) * (c[k] * pdf[k]);
  }
  if (!(s1 > 0)) return 0;
  return power ? c[chosen] * pdf[chosen] / s2 : 1 / s1;
}

// The techniques of a MIS estimator: their fractions.
int techniques(const Problem& p, Estimator e, double* c) {
  const MisOptions& m = p.mis;
  switch (e) {
    case Estimator::MisLightCdf:  // light, table CDF
    case Estimator::MisLightRgl:  // light, the RGL file's warps
      c[0] = m.light_fraction;
      c[1] = 1 - m.light_fraction;
      return 2;
    case Estimator::MisLightGmm:  // light, mixture, uniform
      c[0] = m.light_fraction;
      c[1] = (1 - m.light_fraction) * (1 - m.uniform_fraction);
      c[2] = (1 - m.light_fraction) * m.uniform_fraction;
      return 3;
    case Estimator::MisProduct:  // product, light, uniform
      c[0] = m.product_fraction;
      c[1] = m.product_light;
      c[2] = 1 - m.product_fraction - m.product_light;
      return 3;
    default: return 0;
  }
}

// The densities of the techniques of `e` at (th, ph), in techniques() order.
void technique_pdfs(const Problem& p, Estimator e, double th, double ph, double* pdf) {
  const Domain d = p.table.domain;
  const bool in = inside(d, th);
  switch (e) {
    case Estimator::MisLightCdf:
      pdf[0] = light_pdf(p, th, ph);
      pdf[1] = cdf_pdf(p, th, ph);
      break;
    case Estimator::MisLightGmm:
      pdf[0] = light_pdf(p, th, ph);
      pdf[1] = in ? p.set->pdf_omega(p.theta_o, p.phi_o, th, ph) : 0;
      pdf[2] = in ? uniform_pdf(d) : 0;
      break;
    case Estimator::MisProduct:
      pdf[0] = in ? p.product.pdf_omega(d, th, ph) : 0;
      pdf[1] = light_pdf(p, th, ph);
      pdf[2] = in ? uniform_pdf(d) : 0;
      break;
    case Estimator::MisLightRgl:
      pdf[0] = light_pdf(p, th, ph);
      pdf[1] = rgl_pdf(p, th, ph);
      break;
    default: break;
  }
}

}  // namespace

double estimator_pdf(const Problem& p, Estimator e, double th, double ph) {
  const Domain d = p.table.domain;
  if (!inside(d, th)) return 0;
  switch (e) {
    case Estimator::UsTab:
    case Estimator::UsGmm: return uniform_pdf(d);
    case Estimator::IsTab:
    case Estimator::IsGmm: return p.set->pdf_omega(p.theta_o, p.phi_o, th, ph);
    case Estimator::MisTab:
      return p.mis.uniform_fraction * uniform_pdf(d) +
             (1 - p.mis.uniform_fraction) * p.set->pdf_omega(p.theta_o, p.phi_o, th, ph);
    case Estimator::CdfTab: return cdf_pdf(p, th, ph);
    case Estimator::Light: return light_pdf(p, th, ph);
    case Estimator::Product: return p.has_product ? p.product.pdf_omega(d, th, ph) : 0;
    case Estimator::IsRgl: return rgl_pdf(p, th, ph);
    case Estimator::MisLightCdf:
    case Estimator::MisLightGmm:
    case Estimator::MisProduct:
    case Estimator::MisLightRgl: {
      double c[3], pdf[3];
      const int n = techniques(p, e, c);
      technique_pdfs(p, e, th, ph, pdf);
      double s = 0;
      for (int k = 0; k < n; ++k) s += c[k] * pdf[k];
      return s;
    }
  }
  return 0;
}

bool draw_cpu(const Problem& p, Estimator e, const double u[4], double& th, double& ph) {
  const Domain d = p.table.domain;
  switch (e) {
    case Estimator::UsTab:
    case Estimator::UsGmm: uniform_draw(d, u[2], u[3], th, ph); return true;
    case Estimator::IsTab:
    case Estimator::IsGmm: {
      const mix::Sample s = p.set->sample(p.theta_o, p.phi_o, u[0], u[1], u[2], u[3]);
      th = s.theta;
      ph = s.phi;
      return s.valid;
    }
    case Estimator::MisTab: {
      const double a = p.mis.uniform_fraction;
      if (u[0] < a) {
        uniform_draw(d, u[2], u[3], th, ph);
        return true;
      }
      const mix::Sample s = p.set->sample(p.theta_o, p.phi_o, (u[0] - a) / (1 - a), u[1], u[2], u[3]);
      th = s.theta;
      ph = s.phi;
      return inside(d, th);
    }
    case Estimator::CdfTab: return cdf_draw(p, u[0], u[1], u[2], u[3], th, ph);
    case Estimator::Light: light_draw(p, u[0], u[1], u[2], u[3], th, ph); return inside(d, th);
    case Estimator::Product: {
      if (!p.has_product) return false;
      const mix::Sample s = p.product.sample(d, u[1], u[2], u[3]);
      th = s.theta;
      ph = s.phi;
      return s.valid;
    }
    case Estimator::IsRgl: return rgl_draw(p, u[1], u[2], th, ph);
    default: throw std::invalid_argument(std::string("draw_cpu: not for ") + estimator_name(e));
  }
}

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
      const double a = p.mis.uniform_fraction;
      double th, ph;
      if (u[0] < a) {
        uniform_draw(d, u[2], u[3], th, ph);
      } else {
        const mix::Sample s = set.sample(to, po, (u[0] - a) / (1 - a), u[1], u[2], u[3]);
        if (!(s.theta >= theta_lo(d) && s.theta <= theta_hi(d))) return 0;
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
      double th, ph;
      if (!(pc > 0) || !cdf_draw(p, u[0], u[1], u[2], u[3], th, ph)) return 0;
      return p.light.radiance(th, ph) * double(t.f[i * t.n_phi + j]) * t.cell_weight(i) / pc;
    }
    case Estimator::Light: {
      double th, ph;
      light_draw(p, u[0], u[1], u[2], u[3], th, ph);
      if (!inside(d, th)) return 0;
      const double f = p.table.f_at(th, ph);
      const double pdf = light_pdf(p, th, ph);
      if (f == 0 || !(pdf > 0)) return 0;
      return p.light.radiance(th, ph) * f * cos_factor(d, th) / pdf;
    }
    case Estimator::Product: {
      if (!p.has_product) return 0;
      const mix::Sample s = p.product.sample(d, u[1], u[2], u[3]);
      if (!s.valid) return 0;
      const double f = p.table.f_at(s.theta, s.phi);
      if (f == 0) return 0;
      return p.light.radiance(s.theta, s.phi) * f * cos_factor(d, s.theta) / s.pdf_omega;
    }
    case Estimator::IsRgl: {
      double th, ph, pdf = 0;
      if (!rgl_draw(p, u[1], u[2], th, ph, &pdf)) return 0;
      const double f = p.table.f_at(th, ph);
      if (f == 0 || !(pdf > 0)) return 0;
      return p.light.radiance(th, ph) * f * cos_factor(d, th) / pdf;
    }
    case Estimator::MisLightCdf:
    case Estimator::MisLightGmm:
    case Estimator::MisProduct:
    case Estimator::MisLightRgl: {
      if (e == Estimator::MisProduct && !p.has_product) return 0;
      double c[3], pdf[3];
      const int n = techniques(p, e, c);
      // the technique: u0 split by the fractions, its remainder reused as the technique's u0
      int k = 0;
      double lo = 0;
      while (k + 1 < n && u[0] >= lo + c[k]) lo += c[k++];
      const double r0 = std::clamp((u[0] - lo) / c[k], 0.0, 1.0 - 1e-17);
      double th = 0, ph = 0;
      const bool light = (e == Estimator::MisProduct) ? k == 1 : k == 0;
      const bool uniform = (e == Estimator::MisLightGmm || e == Estimator::MisProduct) && k == 2;
      if (light) {
        light_draw(p, r0, u[1], u[2], u[3], th, ph);
      } else if (uniform) {
        uniform_draw(d, u[2], u[3], th, ph);
      } else if (e == Estimator::MisLightCdf) {
        if (!cdf_draw(p, r0, u[1], u[2], u[3], th, ph)) return 0;
      } else if (e == Estimator::MisLightRgl) {
        if (!rgl_draw(p, u[1], u[2], th, ph)) return 0;
      } else if (e == Estimator::MisLightGmm) {
        const mix::Sample s = set.sample(to, po, r0, u[1], u[2], u[3]);
        th = s.theta;
        ph = s.phi;
      } else {
        const mix::Sample s = p.product.sample(d, u[1], u[2], u[3]);
        th = s.theta;
        ph = s.phi;
      }
      if (!inside(d, th)) return 0;
      const double f = p.table.f_at(th, ph);
      if (f == 0) return 0;
      technique_pdfs(p, e, th, ph, pdf);
      const double w = mis_weight(c, pdf, n, k, p.mis.power);
      return w > 0 ? p.light.radiance(th, ph) * f * cos_factor(d, th) * w : 0;
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
