// Double-precision reference of the Chiang et al. 2016 fiber model (see fiber_model.hpp).
#include "tables/fiber_model.hpp"

#include <cmath>
#include <string>

#include "core/color.hpp"
#include "core/domain.hpp"
#include "core/error.hpp"

namespace bsdfmix {

namespace {

double sqr(double x) { return x * x; }
double safe_sqrt(double x) { return std::sqrt(std::max(0.0, x)); }
double safe_asin(double x) { return std::asin(std::min(1.0, std::max(-1.0, x))); }

// Unpolarized Fresnel reflectance of a dielectric interface entered from air at cosine
// cos_i (>= 0) into a medium of index eta > 1.
double fresnel_dielectric(double cos_i, double eta) {
  cos_i = std::min(1.0, std::max(0.0, cos_i));
  const double sin_t = safe_sqrt(1 - cos_i * cos_i) / eta;
  const double cos_t = safe_sqrt(1 - sin_t * sin_t);
  const double r_par = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
  const double r_perp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
  return 0.5 * (r_par * r_par + r_perp * r_perp);
}

// log(I0(x) exp(-x)), x >= 0: power series below 30, asymptotic expansion above.
double log_i0_scaled(double x) {
  if (x < 30.0) {
    const double q = 0.25 * x * x;
    double term = 1.0, sum = 1.0;
    for (int i = 1; i < 200; ++i) {
      term *= q / (double(i) * double(i));
      sum += term;
      if (term < 1e-17 * sum) break;
    }
    return std::log(sum) - x;
  }
  // I0(x) ~ e^x / sqrt(2 pi x) * sum_n ((2n-1)!!)^2 / (n! (8x)^n)
  double term = 1.0, sum = 1.0;
  for (int n = 1; n <= 12; ++n) {
    term *= sqr(2.0 * n - 1.0) / (double(n) * 8.0 * x);
    sum += term;
  }
  return -0.5 * std::log(2 * kPi * x) + std::log(sum);
}

// The trimmed logistic on [-pi, pi] with scale s, at x in [-pi, pi].
double trimmed_logistic(double x, double s) {
  const double e = std::exp(-std::abs(x) / s);
  const double logistic = e / (s * sqr(1 + e));
  const double norm = 1 / (1 + std::exp(-kPi / s)) - 1 / (1 + std::exp(kPi / s));
  return logistic / norm;
}

// Legendre polynomial P_n(x) and its derivative.
void legendre(std::size_t n, double x, double& p, double& dp) {
  double p0 = 1, p1 = x;
  if (n == 0) {
    p = 1;
    dp = 0;
    return;
  }
  for (std::size_t k = 2; k <= n; ++k) {
    const double pk = ((2.0 * k - 1) * x * p1 - (k - 1.0) * p0) / double(k);
    p0 = p1;
    p1 = pk;
  }
  p = p1;
  dp = double(n) * (x * p1 - p0) / (x * x - 1);
}

}  // namespace

GaussLegendre gauss_legendre(std::size_t n) {
  if (n == 0) throw ConfigError("Gauss-Legendre rule: the number of nodes must be at least 1");
  GaussLegendre g;
  g.nodes.resize(n);
  g.weights.resize(n);
  for (std::size_t i = 0; i < (n + 1) / 2; ++i) {
    // Initial guess (Tricomi), then Newton on P_n.
    double x = std::cos(kPi * (double(i) + 0.75) / (double(n) + 0.5));
    double p = 0, dp = 1;
    for (int it = 0; it < 100; ++it) {
      legendre(n, x, p, dp);
      const double dx = p / dp;
      x -= dx;
      if (std::abs(dx) < 1e-16) break;
    }
    legendre(n, x, p, dp);
    const double w = 2 / ((1 - x * x) * dp * dp);
    g.nodes[i] = -x;
    g.nodes[n - 1 - i] = x;
    g.weights[i] = g.weights[n - 1 - i] = w;
  }
  if (n % 2 == 1) g.nodes[n / 2] = 0;
  return g;
}

FiberRgb sigma_a_from_color(const FiberRgb& color, double beta_n) {
  if (!(beta_n > 0.0 && beta_n <= 1.0)) throw ConfigError("sigma_a from a colour: beta_n must be in (0, 1]");
  const double b = beta_n;
  const double d = 5.969 - 0.215 * b + 2.532 * b * b - 10.73 * std::pow(b, 3) + 5.574 * std::pow(b, 4) +
                   0.245 * std::pow(b, 5);
  FiberRgb s{};
  for (int c = 0; c < kFiberChannels; ++c) {
    const double x = color[std::size_t(c)];
    if (!(x > 0.0 && x <= 1.0)) throw ConfigError("sigma_a from a colour: every channel must be in (0, 1]");
    s[std::size_t(c)] = sqr(std::log(x) / d);
  }
  return s;
}

double log_bessel_i0(double x) { return log_i0_scaled(std::abs(x)) + std::abs(x); }
double bessel_i0(double x) { return std::exp(log_bessel_i0(x)); }

FiberModel::FiberModel(const FiberParams& params, std::size_t h_nodes, const char* where) : params_(params) {
  auto fail = [&](const std::string& what) {
    throw ConfigError(std::string(where) + ": " + what);
  };
  if (!(params.eta > 1.0 && params.eta < 10.0)) fail("eta must be in (1, 10)");
  for (double s : params.sigma_a)
    if (!(s >= 0.0 && std::isfinite(s))) fail("sigma_a must be >= 0 in every channel");
  if (!(params.beta_m > 0.0 && params.beta_m <= 1.0)) fail("beta_m must be in (0, 1]");
  if (!(params.beta_n > 0.0 && params.beta_n <= 1.0)) fail("beta_n must be in (0, 1]");
  if (!(std::abs(params.alpha) < kPi / 4)) fail("alpha must be in (-pi/4, pi/4) radians");
  if (h_nodes < 2 || h_nodes > 4096) fail("h_nodes must be in [2, 4096]");

  // Longitudinal variances from beta_m (Chiang et al. 2016, eq. 7).
  const double bm = params.beta_m;
  v_[0] = sqr(0.726 * bm + 0.812 * bm * bm + 3.7 * std::pow(bm, 20));
  v_[1] = 0.25 * v_[0];
  v_[2] = 4 * v_[0];
  v_[3] = v_[2];
  // Logistic scale from beta_n (eq. 8).
  const double bn = params.beta_n;
  s_ = std::sqrt(kPi / 8) * (0.265 * bn + 1.194 * bn * bn + 5.372 * std::pow(bn, 22));
  // sin/cos of alpha, 2 alpha, 4 alpha.
  sin2k_[0] = std::sin(params.alpha);
  cos2k_[0] = std::cos(params.alpha);
  for (int k = 1; k < 3; ++k) {
    sin2k_[k] = 2 * cos2k_[k - 1] * sin2k_[k - 1];
    cos2k_[k] = sqr(cos2k_[k - 1]) - sqr(sin2k_[k - 1]);
  }
  gl_ = gauss_legendre(h_nodes);
}

double FiberModel::longitudinal(int p, double theta_o, double theta_i) const {
  const double sin_o = std::sin(theta_o), cos_o = std::cos(theta_o);
  double sin_op = sin_o, cos_op = cos_o;
  if (p == 0) {  // theta_o - 2 alpha
    sin_op = sin_o * cos2k_[1] - cos_o * sin2k_[1];
    cos_op = cos_o * cos2k_[1] + sin_o * sin2k_[1];
  } else if (p == 1) {  // theta_o + alpha
    sin_op = sin_o * cos2k_[0] + cos_o * sin2k_[0];
    cos_op = cos_o * cos2k_[0] - sin_o * sin2k_[0];
  } else if (p == 2) {  // theta_o + 4 alpha
    sin_op = sin_o * cos2k_[2] + cos_o * sin2k_[2];
    cos_op = cos_o * cos2k_[2] - sin_o * sin2k_[2];
  }
  cos_op = std::abs(cos_op);
  const double sin_i = std::sin(theta_i), cos_i = std::cos(theta_i);
  const double v = v_[static_cast<std::size_t>(p)];
  // M = exp(-b) I0(a) / (2 v sinh(1/v)), a = cos_i cos_o' / v, b = sin_i sin_o' / v,
  // evaluated in logs: 2 v sinh(1/v) = v e^{1/v} (1 - e^{-2/v}), so log M =
  // log(I0(a) e^-a) + (a - b - 1/v) - log(v) - log(1 - e^{-2/v}).
  const double a = cos_i * cos_op / v;
  const double a_minus_b_minus_inv_v = (cos_i * cos_op - sin_i * sin_op - 1) / v;
  const double log_m = log_i0_scaled(a) + a_minus_b_minus_inv_v - std::log(v) - std::log1p(-std::exp(-2 / v));
  return std::exp(log_m);
}

std::array<FiberLobes, kFiberChannels> FiberModel::attenuation(double theta_o, double h) const {
  const double eta = params_.eta;
  const double sin_o = std::sin(theta_o), cos_o = std::max(std::cos(theta_o), 1e-12);
  const double sin_t = sin_o / eta, cos_t = safe_sqrt(1 - sin_t * sin_t);
  const double etap = std::sqrt(eta * eta - sin_o * sin_o) / cos_o;  // modified index (Bravais)
  const double sin_gt = h / etap, cos_gt = safe_sqrt(1 - sin_gt * sin_gt);
  const double path = 2 * cos_gt / cos_t;  // one internal path, in fiber radii
  const double cos_go = safe_sqrt(1 - h * h);
  const double F = fresnel_dielectric(cos_o * cos_go, eta);
  std::array<FiberLobes, kFiberChannels> out{};
  for (int c = 0; c < kFiberChannels; ++c) {
    const double T = std::exp(-params_.sigma_a[std::size_t(c)] * path);
    FiberLobes& a = out[std::size_t(c)];
    a[0] = F;
    a[1] = sqr(1 - F) * T;
    a[2] = a[1] * T * F;
    // Geometric series of the orders p >= 3; at grazing h = +-1 with no absorption T F = 1,
    // where (1 - F)^2 = 0 already: the residual is 0.
    const double denom = 1 - T * F;
    a[3] = denom > 0 ? a[2] * F * T / denom : 0.0;
  }
  return out;
}

double FiberModel::azimuthal(int p, double theta_o, double h, double phi) const {
  if (p >= 3) return 1 / (2 * kPi);
  const double eta = params_.eta;
  const double sin_o = std::sin(theta_o), cos_o = std::max(std::cos(theta_o), 1e-12);
  const double etap = std::sqrt(eta * eta - sin_o * sin_o) / cos_o;
  const double gamma_o = safe_asin(h), gamma_t = safe_asin(h / etap);
  const double center = 2 * p * gamma_t - 2 * gamma_o + p * kPi;
  return trimmed_logistic(wrap_phi(phi - center), s_);
}

FiberRgb FiberModel::f_at_h(double theta_o, double phi_o, double theta_i, double phi_i, double h) const {
  const auto a = attenuation(theta_o, h);
  FiberRgb sum{};
  for (int p = 0; p < kFiberLobes; ++p) {
    const double mn = longitudinal(p, theta_o, theta_i) * azimuthal(p, theta_o, h, phi_i - phi_o);
    for (std::size_t c = 0; c < kFiberChannels; ++c) sum[c] += mn * a[c][static_cast<std::size_t>(p)];
  }
  return sum;
}

FiberRgb FiberModel::f_rgb(double theta_o, double phi_o, double theta_i, double phi_i) const {
  FiberRgb sum{};
  for (std::size_t k = 0; k < gl_.nodes.size(); ++k) {
    const FiberRgb v = f_at_h(theta_o, phi_o, theta_i, phi_i, gl_.nodes[k]);
    for (std::size_t c = 0; c < kFiberChannels; ++c) sum[c] += gl_.weights[k] * v[c];
  }
  for (double& x : sum) x *= 0.5;
  return sum;
}

double FiberModel::f(double theta_o, double phi_o, double theta_i, double phi_i) const {
  const FiberRgb v = f_rgb(theta_o, phi_o, theta_i, phi_i);
  return rec709_luminance(v[0], v[1], v[2]);
}

FiberModel::AzimuthalFactors FiberModel::azimuthal_factors(double theta_o, const std::vector<double>& phi) const {
  AzimuthalFactors out;
  for (auto& channel : out)
    for (auto& v : channel) v.assign(phi.size(), 0.0);
  std::array<double, 3> n{};
  for (std::size_t k = 0; k < gl_.nodes.size(); ++k) {
    const double h = gl_.nodes[k], w = 0.5 * gl_.weights[k];
    const auto a = attenuation(theta_o, h);
    for (std::size_t j = 0; j < phi.size(); ++j) {
      for (int p = 0; p < 3; ++p) n[std::size_t(p)] = w * azimuthal(p, theta_o, h, phi[j]);
      for (std::size_t c = 0; c < kFiberChannels; ++c) {
        for (std::size_t p = 0; p < 3; ++p) out[c][p][j] += a[c][p] * n[p];
        out[c][3][j] += w * a[c][3] / (2 * kPi);
      }
    }
  }
  return out;
}

}  // namespace bsdfmix
