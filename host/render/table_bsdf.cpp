// A tabulated BSDF in memory: the table, its CDFs, the stand-in, the samplers; a hit's frame.
#include "render/table_bsdf.hpp"

#include <algorithm>
#include <cmath>

#include "core/error.hpp"
#include "tables/rgl_brdf.hpp"

namespace bsdfmix {
namespace render {

namespace {

constexpr double kUniformPdfSphere = 1 / (4 * kPi), kUniformPdfHemisphere = 1 / (2 * kPi);

// The unit vector along wo's part perpendicular to the unit `axis` (c = dot(wo, axis)),
// or any unit vector perpendicular to it where wo lies along it: the phi = 0 direction.
Vec3 phi_zero(const Vec3& axis, const Vec3& wo, double c) {
  Vec3 p{wo[0] - c * axis[0], wo[1] - c * axis[1], wo[2] - c * axis[2]};
  if (dot(p, p) < 1e-20) p = std::abs(axis[0]) < 0.9 ? cross(axis, {1, 0, 0}) : cross(axis, {0, 1, 0});
  return normalized(p);
}

}  // namespace

HitFrame::HitFrame(const Vec3& axis, const Vec3& wo, Domain domain) {
  a.axis = normalized(axis);
  a.domain = domain;
  const double c = std::clamp(dot(wo, a.axis), -1.0, 1.0);
  theta_o = domain == Domain::Fiber ? std::asin(c) : std::acos(c);
  a.e1 = phi_zero(a.axis, wo, c);
  a.e2 = cross(a.axis, a.e1);
}

TableBsdf::TableBsdf(const std::string& table_path) : TableBsdf(TableReader(table_path)) {}

TableBsdf::TableBsdf(const TableReader& table) {
  meta_ = table.meta();
  if (!meta_.azimuthal)
    throw InputError(table.path() + ": the renderer needs a table with azimuthal symmetry (one phi_o)");
  uniform_pdf_ = meta_.domain == Domain::Fiber ? kUniformPdfSphere : kUniformPdfHemisphere;
  const std::size_t cells = meta_.cells_per_slice(), no = meta_.theta_o.size();
  f_.resize(no * cells);
  for (std::size_t s = 0; s < no; ++s) {
    const std::vector<float> v = table.read_slice(s, 0);
    std::copy(v.begin(), v.end(), f_.begin() + std::ptrdiff_t(s * cells));
  }
  if (meta_.rgb) {
    rgb_.resize(3 * no * cells);
    for (std::size_t s = 0; s < no; ++s) {
      // A measured channel's cells below zero are noise (cg_sunflower's blue): a
      // reflectance is never negative, so they reflect nothing (docs/render.md).
      const std::vector<float> v = table.read_slice_rgb(s, 0);
      std::transform(v.begin(), v.end(), rgb_.begin() + std::ptrdiff_t(3 * s * cells),
                     [](float x) { return std::max(x, 0.0f); });
    }
  }
  dth_ = axis_step(meta_.theta_i);
  dph_ = axis_step(meta_.phi_i);
  th0_ = meta_.theta_i.front() - dth_ / 2;
  ph0_ = meta_.phi_i.front() - dph_ / 2;
  dto_ = no > 1 ? axis_step(meta_.theta_o) : 1.0;
  to0_ = meta_.theta_o.front();
  // The table CDF of every slice (cdf_tab's, host/sampling/problem.cpp build_cdf).
  for (std::size_t s = 0; s < no; ++s) {
    TableSlice t;
    t.domain = meta_.domain;
    t.n_theta = meta_.theta_i.size();
    t.n_phi = meta_.phi_i.size();
    t.th0 = th0_;
    t.dth = dth_;
    t.ph0 = ph0_;
    t.dph = dph_;
    t.f.assign(f_.begin() + std::ptrdiff_t(s * cells), f_.begin() + std::ptrdiff_t((s + 1) * cells));
    if (s == 0)
      for (std::size_t i = 0; i < t.n_theta; ++i)
        cell_w_.push_back(meta_.domain == Domain::Fiber ? t.cell_weight(i) : t.cell_solid_angle(i));
    bool any = false;
    for (float x : t.f) any = any || x > 0;
    cdf_.push_back(any ? build_cdf(t) : CellCdf{});
  }
  fitted_.assign(no, -1);
}

void TableBsdf::set_mixture(const mix::MixtureSet& set) {
  if (set.domain != meta_.domain)
    throw InputError(std::string("render: the mixture file is not of a ") +
                     (meta_.domain == Domain::Fiber ? "fiber" : "hemisphere") + " table, as the table is");
  set_ = set;
  has_set_ = !set_.slices.empty();
  set_has_rgb_ = false;
  for (const auto& sl : set_.slices) set_has_rgb_ = set_has_rgb_ || sl.has_rgb;
  factors_.assign(set_.slices.size(), ProductFactor{});
  for (std::size_t k = 0; k < set_.slices.size(); ++k) factors_[k].assign(set_.slices[k]);
  fitted_.assign(meta_.theta_o.size(), -1);
  for (std::size_t k = 0; k < set_.slices.size(); ++k) {
    std::size_t best = 0;
    for (std::size_t i = 1; i < meta_.theta_o.size(); ++i)
      if (std::abs(meta_.theta_o[i] - set_.slices[k].theta_o) < std::abs(meta_.theta_o[best] - set_.slices[k].theta_o))
        best = i;
    fitted_[best] = int(k);
  }
}

void TableBsdf::set_rgl(const RglBrdf* rgl) {
  if (rgl && meta_.domain != Domain::Hemisphere)
    throw InputError("render: the RGL sampler serves a measured surface (a hemisphere table), not a fiber table");
  rgl_ = rgl;
}

void TableBsdf::bracket(double theta_o, std::size_t& i0, std::size_t& i1, double& w) const {
  const Bracket b = mix::bracket(to0_, dto_, meta_.theta_o.size(), theta_o, false);
  i0 = b.i0;
  i1 = b.i1;
  w = b.f;
}

long TableBsdf::cell_of(double theta, double phi) const {
  const double fi = std::floor((theta - th0_) / dth_);
  const std::size_t nt = meta_.theta_i.size(), np = meta_.phi_i.size();
  if (!(fi >= 0) || fi >= double(nt)) return -1;
  long j = long(std::floor((phi - ph0_) / dph_)) % long(np);
  if (j < 0) j += long(np);
  return long(std::size_t(fi) * np + std::size_t(j));
}

double TableBsdf::cell_f(std::size_t slice, double theta, double phi) const {
  const long c = cell_of(theta, phi);
  return c < 0 ? 0.0 : f_[slice * meta_.cells_per_slice() + std::size_t(c)];
}

bool TableBsdf::bracketed(double theta_o) const {
  std::size_t i0, i1;
  double w;
  bracket(theta_o, i0, i1, w);
  return (w < 1 && fitted_[i0] >= 0) || (w > 0 && fitted_[i1] >= 0);
}

int TableBsdf::nearest_fitted(double theta_o) const {
  int best = -1;
  double d = 1e300;
  for (std::size_t i = 0; i < fitted_.size(); ++i)
    if (fitted_[i] >= 0 && std::abs(meta_.theta_o[i] - theta_o) < d) {
      d = std::abs(meta_.theta_o[i] - theta_o);
      best = fitted_[i];
    }
  return best;
}

double TableBsdf::f(FSource which, double theta_o, double theta, double phi) const {
  if (which == FSource::Table) {
    std::size_t i0, i1;
    double w;
    bracket(theta_o, i0, i1, w);
    const double a = cell_f(i0, theta, phi);
    return w > 0 ? (1 - w) * a + w * cell_f(i1, theta, phi) : a;
  }
  if (!has_set_) throw InputError("render: the stand-in needs the mixtures");
  if (bracketed(theta_o)) return set_.eval_f(theta_o, 0.0, theta, phi);
  const mix::SliceMixture& s = set_.slices[std::size_t(nearest_fitted(theta_o))];
  if (meta_.domain == Domain::Fiber) {
    const double j = std::cos(theta);
    return j > 0 ? s.scale * s.pdf_param(theta, phi) / j : 0.0;
  }
  const double j = std::sin(theta) * std::cos(theta);  // J and the cosine of the integrand
  return j > 0 && theta <= kPi / 2 ? s.scale * s.pdf_param(theta, phi) / j : 0.0;
}

Rgb TableBsdf::f_rgb(FSource which, double theta_o, double theta, double phi) const {
  if (which == FSource::Table) {
    if (rgb_.empty()) return Rgb(f(which, theta_o, theta, phi));
    std::size_t i0, i1;
    double w;
    bracket(theta_o, i0, i1, w);
    const long c = cell_of(theta, phi);
    if (c < 0) return Rgb();
    const std::size_t cells = meta_.cells_per_slice();
    Rgb out;
    for (int k = 0; k < 3; ++k) {
      const double a = rgb_[3 * (i0 * cells + std::size_t(c)) + std::size_t(k)];
      out[k] = w > 0 ? (1 - w) * a + w * double(rgb_[3 * (i1 * cells + std::size_t(c)) + std::size_t(k)]) : a;
    }
    return out;
  }
  // The stand-in: its rgb amplitudes where the mixture file has them (eval_rgb, blended
  // between slices as eval_f), else the luminance in every channel.
  if (!has_set_ || !set_has_rgb_) return Rgb(f(which, theta_o, theta, phi));
  double c[3];
  if (bracketed(theta_o)) {
    set_.eval_rgb(theta_o, 0.0, theta, phi, c);
    return Rgb(c[0], c[1], c[2]);
  }
  const mix::SliceMixture& s = set_.slices[std::size_t(nearest_fitted(theta_o))];
  const double j = meta_.domain == Domain::Fiber ? std::cos(theta) : std::sin(theta) * std::cos(theta);
  if (!(j > 0) || theta < theta_lo(meta_.domain) || theta > kPi / 2) return Rgb();
  s.eval_rgb_param(theta, phi, c);
  return Rgb(c[0] / j, c[1] / j, c[2] / j);
}

double TableBsdf::share(double theta_o) const {
  if (uniform_fraction >= 0 || !has_set_) return uniform_fraction >= 0 ? uniform_fraction : 0.1;
  if (bracketed(theta_o)) return set_.defensive(theta_o, 0.0);
  return set_.slices[std::size_t(nearest_fitted(theta_o))].defensive;
}

mix::Sample TableBsdf::mixture_sample(double theta_o, const double u[4]) const {
  if (bracketed(theta_o)) return set_.sample(theta_o, 0.0, u[0], u[1], u[2], u[3]);
  return set_.slices[std::size_t(nearest_fitted(theta_o))].sample(meta_.domain, u[1], u[2], u[3]);
}

double TableBsdf::mixture_pdf(double theta_o, double theta, double phi) const {
  if (bracketed(theta_o)) return set_.pdf_omega(theta_o, 0.0, theta, phi);
  return set_.slices[std::size_t(nearest_fitted(theta_o))].pdf_omega(meta_.domain, theta, phi);
}

int TableBsdf::product_slice(double theta_o) const {
  if (!has_set_) throw InputError("render: product sampling needs the mixtures");
  // the nearer of the two slices around theta_o when it is fitted (half the pairs of the
  // blend; the product's pdf is its own, so this costs variance, never bias)
  std::size_t i0, i1;
  double w;
  bracket(theta_o, i0, i1, w);
  const std::size_t near = w < 0.5 ? i0 : i1;
  return fitted_[near] >= 0 ? fitted_[near] : nearest_fitted(theta_o);
}

mix::SliceMixture TableBsdf::product(double theta_o, const mix::SliceMixture& lighting,
                                     const mix::ProductOptions& o) const {
  return mix::product(set_.slices[std::size_t(product_slice(theta_o))], 0.0, lighting, o);
}

const ProductFactor& TableBsdf::product_factor(double theta_o) const {
  return factors_[std::size_t(product_slice(theta_o))];
}

void TableBsdf::sample(BsdfSampler s, double theta_o, const double u[4], double& theta, double& phi,
                       double& pdf_out) const {
  pdf_out = 0;
  if (s == BsdfSampler::Rgl) {
    // the file's warps for the view omega_o = (sin theta_o, 0, cos theta_o), phi = 0 its plane
    if (!rgl_) throw InputError("render: the RGL sampler needs the RGL file (import.rgl)");
    const RglBrdf::Sample r = rgl_->sample({std::sin(theta_o), 0.0, std::cos(theta_o)}, u[1], u[2]);
    if (!r.valid) return;
    theta = std::acos(std::clamp(r.omega_i[2], 0.0, 1.0));
    phi = std::atan2(r.omega_i[1], r.omega_i[0]);
    if (!(theta <= kPi / 2)) return;
    pdf_out = r.pdf;  // the warps' density there: what pdf() gives
    return;
  }
  const double a = s == BsdfSampler::Mixture ? share(theta_o) : 0.0;
  if (s == BsdfSampler::Uniform || (s == BsdfSampler::Mixture && u[0] < a)) {
    // uniform over the domain's sphere or hemisphere of directions
    theta = meta_.domain == Domain::Fiber ? std::asin(std::clamp(2 * u[2] - 1, -1.0, 1.0))
                                          : std::acos(std::clamp(u[2], 0.0, 1.0));
    phi = 2 * kPi * u[3] - kPi;
  } else if (s == BsdfSampler::Mixture) {
    if (!has_set_) throw InputError("render: mixture sampling needs the mixtures");
    const double v[4] = {(u[0] - a) / (1 - a), u[1], u[2], u[3]};
    const mix::Sample m = mixture_sample(theta_o, v);
    if (!m.valid) return;
    theta = m.theta;
    phi = m.phi;
    // the sampler already evaluated the mixture's density there: the same number pdf()
    // would compute again (MixtureSet::sample calls pdf_omega at the sample)
    pdf_out = a * uniform_pdf_ + (1 - a) * m.pdf_omega;
    return;
  } else {
    // the table CDF of one of the two slices around theta_o, picked by its weight
    std::size_t i0, i1;
    double w;
    bracket(theta_o, i0, i1, w);
    const std::size_t sl = (w > 0 && u[0] >= 1 - w) ? i1 : i0;
    const CellCdf& c = cdf_[sl];
    if (c.marginal.empty()) return;
    const std::size_t nt = meta_.theta_i.size(), np = meta_.phi_i.size();
    const std::size_t i = cdf_find(c.marginal.data(), nt, u[1]);
    const float* row = &c.conditional[i * (np + 1)];
    const std::size_t j = cdf_find(row, np, u[2]);
    const double lo = theta_lo(meta_.domain);
    const double t0 = std::max(th0_ + dth_ * double(i), lo), t1 = std::min(th0_ + dth_ * double(i + 1), kPi / 2);
    // u[3] places the point, uniformly in solid angle within the cell: its two halves for
    // theta (sin uniform for fibers, J = cos; cos uniform for the hemisphere, J = sin) and phi
    const double v = u[3] * 4096.0, vt = std::floor(v) / 4096.0, vp = v - std::floor(v);
    theta = meta_.domain == Domain::Fiber
                ? std::asin(std::clamp(std::sin(t0) + vt * (std::sin(t1) - std::sin(t0)), -1.0, 1.0))
                : std::acos(std::clamp(std::cos(t0) + vt * (std::cos(t1) - std::cos(t0)), 0.0, 1.0));
    phi = wrap_phi(ph0_ + dph_ * (double(j) + vp));
  }
  pdf_out = pdf(s, theta_o, theta, phi);
}

double TableBsdf::pdf(BsdfSampler s, double theta_o, double theta, double phi) const {
  if (!(theta >= theta_lo(meta_.domain) && theta <= kPi / 2)) return 0;
  if (s == BsdfSampler::Uniform) return uniform_pdf_;
  if (s == BsdfSampler::Rgl) {
    if (!rgl_) throw InputError("render: the RGL sampler needs the RGL file (import.rgl)");
    const double st = std::sin(theta);
    return rgl_->pdf({std::sin(theta_o), 0.0, std::cos(theta_o)}, {st * std::cos(phi), st * std::sin(phi), std::cos(theta)});
  }
  if (s == BsdfSampler::Mixture) {
    const double a = share(theta_o);
    return a * uniform_pdf_ + (1 - a) * mixture_pdf(theta_o, theta, phi);
  }
  std::size_t i0, i1;
  double w;
  bracket(theta_o, i0, i1, w);
  const double fi = std::floor((theta - th0_) / dth_);
  const std::size_t nt = meta_.theta_i.size(), np = meta_.phi_i.size();
  if (!(fi >= 0) || fi >= double(nt)) return 0;
  const std::size_t i = std::size_t(fi);
  long j = long(std::floor((phi - ph0_) / dph_)) % long(np);
  if (j < 0) j += long(np);
  auto cell_p = [&](std::size_t sl) {
    const CellCdf& c = cdf_[sl];
    if (c.marginal.empty()) return 0.0;
    const float* row = &c.conditional[i * (np + 1)];
    return double(c.marginal[i + 1] - c.marginal[i]) * double(row[j + 1] - row[j]) / cell_w_[i];
  };
  return w > 0 ? (1 - w) * cell_p(i0) + w * cell_p(i1) : cell_p(i0);
}

}  // namespace render
}  // namespace bsdfmix
