// Measured RGL BRDFs: the interpolants and warps of the file, and f in our convention.
#include "tables/rgl_brdf.hpp"

#include <algorithm>
#include <cmath>

#include "core/domain.hpp"
#include "core/error.hpp"
#include "core/format.hpp"
#include "tables/rgl_file.hpp"

namespace bsdfmix {

// ---------------------------------------------------------------- RglWarp2D

namespace {

// The largest i in [0, n - 2] with pred(i) true (0 when none); pred monotone (true then false).
template <class Pred>
std::size_t find_interval(std::size_t n, Pred pred) {
  std::size_t lo = 0, hi = n - 1;  // invariant: answer in [lo, hi - 1]
  while (hi - lo > 1) {
    const std::size_t mid = lo + (hi - lo) / 2;
    if (pred(mid)) lo = mid; else hi = mid;
  }
  return lo;
}

double clamp01(double x) { return x < 0.0 ? 0.0 : (x > 1.0 ? 1.0 : x); }

}  // namespace

RglWarp2D::RglWarp2D(const std::vector<double>& data, std::size_t nx, std::size_t ny,
                     std::vector<std::vector<double>> params, bool density)
    : nx_(nx), ny_(ny), density_(density), params_(std::move(params)), data_(data) {
  const std::size_t size = nx * ny;
  const std::size_t slices = size ? data.size() / size : 0;
  if (!density) return;
  cond_cdf_.assign(data.size(), 0.0);
  marg_cdf_.assign(slices * ny, 0.0);
  for (std::size_t s = 0; s < slices; ++s) {
    double* d = data_.data() + s * size;
    double* cc = cond_cdf_.data() + s * size;
    double* mc = marg_cdf_.data() + s * ny;
    // Conditional CDF along x of each row (trapezoids between nodes), in node units.
    for (std::size_t y = 0; y < ny; ++y) {
      double sum = 0.0;
      cc[y * nx] = 0.0;
      for (std::size_t x = 0; x + 1 < nx; ++x) {
        sum += 0.5 * (d[y * nx + x] + d[y * nx + x + 1]);
        cc[y * nx + x + 1] = sum;
      }
    }
    // Marginal CDF along y of the row totals.
    double sum = 0.0;
    mc[0] = 0.0;
    for (std::size_t y = 0; y + 1 < ny; ++y) {
      sum += 0.5 * (cc[y * nx + nx - 1] + cc[(y + 1) * nx + nx - 1]);
      mc[y + 1] = sum;
    }
    const double norm = sum > 0.0 ? 1.0 / sum : 0.0;  // callers reject empty slices
    for (std::size_t k = 0; k < size; ++k) {
      d[k] *= norm;
      cc[k] *= norm;
    }
    for (std::size_t y = 0; y < ny; ++y) mc[y] *= norm;
  }
}

int RglWarp2D::corners(const double* param, Corner* out) const {
  int n = 1;
  out[0] = {0, 1.0};
  for (std::size_t dim = 0; dim < params_.size(); ++dim) {
    const auto& axis = params_[dim];
    // Slice stride of this parameter: product of the later parameters' sizes.
    std::size_t stride = 1;
    for (std::size_t k = dim + 1; k < params_.size(); ++k) stride *= params_[k].size();
    std::size_t i0 = 0;
    double w1 = 0.0;
    if (axis.size() > 1) {
      const double p = param[dim];
      i0 = find_interval(axis.size(), [&](std::size_t i) { return axis[i] < p; });
      w1 = clamp01((p - axis[i0]) / (axis[i0 + 1] - axis[i0]));
    }
    for (int k = 0; k < n; ++k) {
      const Corner c = out[k];
      out[k] = {c.slice + i0 * stride, c.weight * (1.0 - w1)};
      if (axis.size() > 1) out[n + k] = {c.slice + (i0 + 1) * stride, c.weight * w1};
    }
    if (axis.size() > 1) n *= 2;
  }
  return n;
}

double RglWarp2D::lookup(const std::vector<double>& a, std::size_t stride, std::size_t index, const Corner* c,
                         int n) const {
  double v = 0.0;
  for (int k = 0; k < n; ++k)
    if (c[k].weight != 0.0) v += c[k].weight * a[c[k].slice * stride + index];
  return v;
}

RglWarp2D::Cell RglWarp2D::cell_at(double x, double y, const double* param) const {
  Cell k;
  k.nc = corners(param, k.c);
  const double px = clamp01(x) * double(nx_ - 1), py = clamp01(y) * double(ny_ - 1);
  k.ix = std::min(std::size_t(px), nx_ - 2);
  k.iy = std::min(std::size_t(py), ny_ - 2);
  k.fx = px - double(k.ix);
  k.fy = py - double(k.iy);
  const std::size_t size = nx_ * ny_;
  k.i = k.iy * nx_ + k.ix;
  k.v00 = lookup(data_, size, k.i, k.c, k.nc);
  k.v10 = lookup(data_, size, k.i + 1, k.c, k.nc);
  k.v01 = lookup(data_, size, k.i + nx_, k.c, k.nc);
  k.v11 = lookup(data_, size, k.i + nx_ + 1, k.c, k.nc);
  return k;
}

double RglWarp2D::eval(double x, double y, const double* param) const {
  const Cell k = cell_at(x, y, param);
  const double v = (1.0 - k.fy) * ((1.0 - k.fx) * k.v00 + k.fx * k.v10) + k.fy * ((1.0 - k.fx) * k.v01 + k.fx * k.v11);
  return density_ ? v * double(nx_ - 1) * double(ny_ - 1) : v;
}

std::array<double, 3> RglWarp2D::invert(double x, double y, const double* param) const {
  const Cell k = cell_at(x, y, param);
  const Corner* c = k.c;
  const int nc = k.nc;
  const std::size_t iy = k.iy, i = k.i, size = nx_ * ny_;
  const double fx = k.fx, fy = k.fy;
  const double c0 = (1.0 - fy) * k.v00 + fy * k.v01, c1 = (1.0 - fy) * k.v10 + fy * k.v11;
  const double pdf = (1.0 - fx) * c0 + fx * c1;
  // x: the mass of the row (interpolated at fy) left of the point, over the row's total.
  double sx = fx * (c0 + 0.5 * fx * (c1 - c0));
  sx += (1.0 - fy) * lookup(cond_cdf_, size, i, c, nc) + fy * lookup(cond_cdf_, size, i + nx_, c, nc);
  const double r0 = lookup(cond_cdf_, size, iy * nx_ + nx_ - 1, c, nc),
               r1 = lookup(cond_cdf_, size, (iy + 1) * nx_ + nx_ - 1, c, nc);
  const double row = (1.0 - fy) * r0 + fy * r1;
  sx = row > 0.0 ? sx / row : 0.0;
  // y: the marginal mass below the point.
  const double sy = fy * (r0 + 0.5 * fy * (r1 - r0)) + lookup(marg_cdf_, ny_, iy, c, nc);
  return {sx, sy, pdf * double(nx_ - 1) * double(ny_ - 1)};
}

std::array<double, 3> RglWarp2D::sample(double u, double v, const double* param) const {
  Corner c[8];
  const int nc = corners(param, c);
  const double eps = 1e-12;
  u = std::min(std::max(u, eps), 1.0 - eps);
  v = std::min(std::max(v, eps), 1.0 - eps);
  const std::size_t size = nx_ * ny_;
  // Row from the marginal CDF, then the position inside the row pair (linear density).
  const std::size_t iy = find_interval(ny_, [&](std::size_t k) { return lookup(marg_cdf_, ny_, k, c, nc) < v; });
  v -= lookup(marg_cdf_, ny_, iy, c, nc);
  const double r0 = lookup(cond_cdf_, size, iy * nx_ + nx_ - 1, c, nc),
               r1 = lookup(cond_cdf_, size, (iy + 1) * nx_ + nx_ - 1, c, nc);
  auto solve = [](double a0, double a1, double m) {  // t in [0,1] with t a0 + t^2 (a1 - a0) / 2 = m
    if (std::abs(a0 - a1) < 1e-9 * (a0 + a1)) return a0 + a1 > 0.0 ? 2.0 * m / (a0 + a1) : 0.0;
    return (a0 - std::sqrt(std::max(0.0, a0 * a0 - 2.0 * m * (a0 - a1)))) / (a0 - a1);
  };
  const double fy = clamp01(solve(r0, r1, v));
  // Column from the conditional CDF of the interpolated row.
  u *= (1.0 - fy) * r0 + fy * r1;
  auto cond = [&](std::size_t k) {
    return (1.0 - fy) * lookup(cond_cdf_, size, iy * nx_ + k, c, nc) +
           fy * lookup(cond_cdf_, size, (iy + 1) * nx_ + k, c, nc);
  };
  const std::size_t ix = find_interval(nx_, [&](std::size_t k) { return cond(k) < u; });
  u -= cond(ix);
  const std::size_t i = iy * nx_ + ix;
  const double v00 = lookup(data_, size, i, c, nc), v10 = lookup(data_, size, i + 1, c, nc),
               v01 = lookup(data_, size, i + nx_, c, nc), v11 = lookup(data_, size, i + nx_ + 1, c, nc);
  const double c0 = (1.0 - fy) * v00 + fy * v01, c1 = (1.0 - fy) * v10 + fy * v11;
  const double fx = clamp01(solve(c0, c1, u));
  return {(double(ix) + fx) / double(nx_ - 1), (double(iy) + fy) / double(ny_ - 1),
          ((1.0 - fx) * c0 + fx * c1) * double(nx_ - 1) * double(ny_ - 1)};
}

// ---------------------------------------------------------------- RglBrdf

namespace {

std::string shape_text(const std::vector<std::string>& dims) {
  std::string s = "[";
  for (std::size_t k = 0; k < dims.size(); ++k) s += (k ? ", " : "") + dims[k];
  return s + "]";
}

// How far below zero a value of a non-negative field may lie and still count as zero: a
// few float32 ulps of the field's largest magnitude (the RGL database's files hold such
// rounding negatives, about -4e-10 in a luminance warp; Mitsuba and pbrt load them).
constexpr double kRoundingZero = 8 * 1.1920928955078125e-07;

// Checks dtype float32, rank and the extents given (-1: any >= 2); returns the values.
// With `non_negative`, values within float rounding of zero below it (kRoundingZero times
// the field's largest magnitude) are set to 0 and counted in `zeroed`; other negatives are
// refused.
std::vector<double> load_float(const RglFile& file, const std::string& name, const std::vector<long long>& want,
                               bool non_negative, std::size_t* zeroed = nullptr) {
  const RglField& f = file.field(name);
  const std::string where = file.path() + ": field '" + name + "'";
  if (f.dtype != std::uint8_t(RglDtype::Float32))
    throw InputError(where + ": dtype " + rgl_dtype_name(f.dtype) + ", expected float32");
  bool ok = f.shape.size() == want.size();
  std::vector<std::string> dims;
  for (std::size_t k = 0; k < want.size(); ++k) {
    dims.push_back(want[k] < 0 ? ">=2" : std::to_string(want[k]));
    if (ok) ok = want[k] < 0 ? f.shape[k] >= 2 : f.shape[k] == std::uint64_t(want[k]);
  }
  if (!ok) throw InputError(where + ": wrong dimensions " + f.shape_text() + ", expected " + shape_text(dims));
  std::vector<double> v = file.as_double(f);
  double largest = 0;
  for (std::size_t k = 0; k < v.size(); ++k) {
    if (!std::isfinite(v[k])) throw InputError(where + ": element " + std::to_string(k) + " is not finite");
    largest = std::max(largest, std::abs(v[k]));
  }
  if (!non_negative) return v;
  for (std::size_t k = 0; k < v.size(); ++k) {
    if (!(v[k] < 0.0)) continue;
    if (-v[k] > kRoundingZero * largest)
      throw InputError(where + ": element " + std::to_string(k) + " is negative (" + format_number(v[k], "%.9g") +
                       ", beyond float rounding of zero for values up to " + format_number(largest, "%.9g") + ")");
    v[k] = 0.0;
    if (zeroed) ++*zeroed;
  }
  return v;
}

// Numerically stable polar angle of a unit vector (2 asin(|d - z| / 2)).
double elevation(const std::array<double, 3>& d) {
  const double dist = std::sqrt(d[0] * d[0] + d[1] * d[1] + (d[2] - 1.0) * (d[2] - 1.0));
  return 2.0 * std::asin(std::min(1.0, 0.5 * dist));
}

double theta2u(double theta) { return std::sqrt(std::max(0.0, theta) * (2.0 / kPi)); }
double phi2u(double phi) { return (phi + kPi) * (0.5 / kPi); }

}  // namespace

RglBrdf::RglBrdf(const std::string& path) : path_(path) {
  const RglFile file(path);
  sha256_ = sha256_hex(file.bytes());
  if (const RglField* d = file.find("description")) description_ = file.as_text(*d);

  if (!file.find("rgb") && file.find("spectra"))
    throw InputError(path + ": spectral data (field 'spectra') not handled: only RGB files (field 'rgb')");

  // Parameter axes: the view direction's azimuth and elevation.
  const RglField& phi_f = file.field("phi_i");
  if (phi_f.shape.size() != 1 || phi_f.shape[0] < 1)
    throw InputError(path + ": field 'phi_i': wrong dimensions " + phi_f.shape_text() + ", expected [1]");
  if (phi_f.shape[0] != 1)
    throw InputError(path + ": anisotropic data (field 'phi_i' has " + std::to_string(phi_f.shape[0]) +
                     " values) not handled: only isotropic files (one phi_i)");
  const std::vector<double> phi_i = load_float(file, "phi_i", {1}, false);
  const RglField& theta_f = file.field("theta_i");
  if (theta_f.shape.size() != 1 || theta_f.shape[0] < 1)
    throw InputError(path + ": field 'theta_i': wrong dimensions " + theta_f.shape_text() + ", expected [n >= 1]");
  const long long n_theta = (long long)theta_f.shape[0];
  theta_axis_ = load_float(file, "theta_i", {n_theta}, true);
  for (std::size_t k = 0; k < theta_axis_.size(); ++k) {
    if (theta_axis_[k] > 0.5 * kPi + 1e-5)
      throw InputError(path + ": field 'theta_i': value " + std::to_string(theta_axis_[k]) + " beyond pi/2");
    if (k && theta_axis_[k] <= theta_axis_[k - 1])
      throw InputError(path + ": field 'theta_i': values not increasing at index " + std::to_string(k));
  }

  // Jacobian flag: whether the stored values are divided by D / (4 sigma).
  const RglField& jac = file.field("jacobian");
  if (jac.dtype != std::uint8_t(RglDtype::UInt8) || jac.shape.size() != 1 || jac.shape[0] != 1)
    throw InputError(path + ": field 'jacobian': " + rgl_dtype_name(jac.dtype) + " " + jac.shape_text() +
                     ", expected uint8 [1]");
  jacobian_ = file.as_double(jac)[0] != 0.0;

  // NDF and projected area: plain interpolants over (u_theta, u_phi), u_theta contiguous.
  const RglField& ndf_f = file.field("ndf");
  if (ndf_f.shape.size() != 2)
    throw InputError(path + ": field 'ndf': wrong dimensions " + ndf_f.shape_text() + ", expected [>=2, >=2]");
  auto ndf = load_float(file, "ndf", {-1, -1}, true, &rounding_zeros_);
  ndf_ = RglWarp2D(ndf, ndf_f.shape[1], ndf_f.shape[0], {}, false);
  const RglField& sigma_f = file.field("sigma");
  if (sigma_f.shape.size() != 2)
    throw InputError(path + ": field 'sigma': wrong dimensions " + sigma_f.shape_text() + ", expected [>=2, >=2]");
  auto sigma = load_float(file, "sigma", {-1, -1}, true, &rounding_zeros_);
  for (std::size_t k = 0; k < sigma.size(); ++k)
    if (!(sigma[k] > 0.0))
      throw InputError(path + ": field 'sigma': element " + std::to_string(k) + " is not positive");
  sigma_ = RglWarp2D(sigma, sigma_f.shape[1], sigma_f.shape[0], {}, false);

  // VNDF and luminance: densities over the unit square, conditioned on (phi_i, theta_i).
  const std::vector<std::vector<double>> params = {phi_i, theta_axis_};
  auto density = [&](const std::string& name, RglWarp2D& out) -> const RglField& {
    const RglField& f = file.field(name);
    if (f.shape.size() != 4)
      throw InputError(path + ": field '" + name + "': wrong dimensions " + f.shape_text() + ", expected [1, " +
                       std::to_string(n_theta) + ", >=2, >=2]");
    auto v = load_float(file, name, {1, n_theta, -1, -1}, true, &rounding_zeros_);
    const std::size_t size = f.shape[2] * f.shape[3];
    for (long long t = 0; t < n_theta; ++t) {
      double sum = 0.0;
      for (std::size_t k = 0; k < size; ++k) sum += v[t * size + k];
      if (!(sum > 0.0))
        throw InputError(path + ": field '" + name + "': the slice of theta_i index " + std::to_string(t) +
                         " is all zero");
    }
    out = RglWarp2D(v, f.shape[3], f.shape[2], params, true);
    return f;
  };
  density("vndf", vndf_);
  const RglField& lum_f = density("luminance", luminance_);

  // RGB: plain interpolant over the luminance warp's domain, per (phi_i, theta_i, channel).
  const long long ny = (long long)lum_f.shape[2], nx = (long long)lum_f.shape[3];
  auto rgb = load_float(file, "rgb", {1, n_theta, 3, ny, nx}, false);
  rgb_ = RglWarp2D(rgb, std::size_t(nx), std::size_t(ny), {phi_i, theta_axis_, {0.0, 1.0, 2.0}}, false);
  res_ = std::size_t(nx);
}

RglValue RglBrdf::eval(const std::array<double, 3>& wo, const std::array<double, 3>& wi) const {
  RglValue out;
  if (!(wo[2] > 0.0) || !(wi[2] > 0.0)) return out;
  // Half vector of the view (the file's tabulated direction) and the light direction.
  std::array<double, 3> m = {wo[0] + wi[0], wo[1] + wi[1], wo[2] + wi[2]};
  const double len = std::sqrt(m[0] * m[0] + m[1] * m[1] + m[2] * m[2]);
  if (!(len > 0.0)) return out;
  for (double& x : m) x /= len;
  const double theta_v = elevation(wo), phi_v = std::atan2(wo[1], wo[0]);
  const double theta_m = elevation(m), phi_m = std::atan2(m[1], m[0]);
  const double u_v[2] = {theta2u(theta_v), phi2u(phi_v)};
  double u_m[2] = {theta2u(theta_m), phi2u(phi_m - phi_v)};  // isotropic: azimuth relative to the view
  u_m[1] -= std::floor(u_m[1]);
  const double params[2] = {phi_v, theta_v};
  const auto s = vndf_.invert(u_m[0], u_m[1], params);
  double scale = 1.0 / wi[2];  // f = stored value * D / (4 sigma) / cos(theta of the light)
  if (jacobian_) scale *= ndf_.eval(u_m[0], u_m[1]) / (4.0 * sigma_.eval(u_v[0], u_v[1]));
  for (int ch = 0; ch < 3; ++ch) {
    const double p[3] = {phi_v, theta_v, double(ch)};
    out.rgb[ch] = rgb_.eval(s[0], s[1], p) * scale;
  }
  out.y = rgb_luminance(out.rgb[0], out.rgb[1], out.rgb[2]);
  return out;
}

RglValue RglBrdf::eval(double theta_o, double phi_o, double theta_i, double phi_i) const {
  const std::array<double, 3> wo = {std::sin(theta_o) * std::cos(phi_o), std::sin(theta_o) * std::sin(phi_o),
                                    std::cos(theta_o)};
  const std::array<double, 3> wi = {std::sin(theta_i) * std::cos(phi_i), std::sin(theta_i) * std::sin(phi_i),
                                    std::cos(theta_i)};
  return eval(wo, wi);
}

double RglBrdf::pdf(const std::array<double, 3>& wo, const std::array<double, 3>& wi) const {
  if (!(wo[2] > 0.0) || !(wi[2] > 0.0)) return 0.0;
  std::array<double, 3> m = {wo[0] + wi[0], wo[1] + wi[1], wo[2] + wi[2]};
  const double len = std::sqrt(m[0] * m[0] + m[1] * m[1] + m[2] * m[2]);
  if (!(len > 0.0)) return 0.0;
  for (double& x : m) x /= len;
  const double theta_v = elevation(wo), phi_v = std::atan2(wo[1], wo[0]);
  const double theta_m = elevation(m), phi_m = std::atan2(m[1], m[0]);
  double u_m[2] = {theta2u(theta_m), phi2u(phi_m - phi_v)};
  u_m[1] -= std::floor(u_m[1]);
  const double params[2] = {phi_v, theta_v};
  const auto s = vndf_.invert(u_m[0], u_m[1], params);
  const double lum_pdf = luminance_.eval(s[0], s[1], params);
  // d(omega_m) = 2 pi^2 u_theta sin(theta_m) du dv; d(omega_i) = 4 (omega_o . m) d(omega_m).
  const double dot = wo[0] * m[0] + wo[1] * m[1] + wo[2] * m[2];
  const double jac = std::max(2.0 * kPi * kPi * u_m[0] * std::sin(theta_m), 1e-12) * 4.0 * dot;
  return s[2] * lum_pdf / jac;
}

RglBrdf::Sample RglBrdf::sample(const std::array<double, 3>& wo, double u1, double u2) const {
  Sample out;
  if (!(wo[2] > 0.0)) return out;
  const double theta_v = elevation(wo), phi_v = std::atan2(wo[1], wo[0]);
  const double params[2] = {phi_v, theta_v};
  // Luminance warp first, then the VNDF warp: a half vector in (u_theta, u_phi).
  const auto l = luminance_.sample(u2, u1, params);
  const auto um = vndf_.sample(l[0], l[1], params);
  const double theta_m = um[0] * um[0] * (kPi / 2), phi_m = (2.0 * um[1] - 1.0) * kPi + phi_v;
  const std::array<double, 3> m = {std::sin(theta_m) * std::cos(phi_m), std::sin(theta_m) * std::sin(phi_m),
                                   std::cos(theta_m)};
  const double dot = wo[0] * m[0] + wo[1] * m[1] + wo[2] * m[2];
  for (int k = 0; k < 3; ++k) out.omega_i[k] = 2.0 * dot * m[k] - wo[k];
  const double jac = std::max(2.0 * kPi * kPi * um[0] * std::sin(theta_m), 1e-12) * 4.0 * dot;
  out.pdf = um[2] * l[2] / jac;
  out.valid = out.omega_i[2] > 0.0 && dot > 0.0 && out.pdf > 0.0;
  return out;
}

}  // namespace bsdfmix
