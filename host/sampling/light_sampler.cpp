// Light sampling of a convergence scene: term powers, the map's pixel distribution, the
// double-precision sampler and density, and the packing for kernels/sample.cl.
#include "sampling/light_sampler.hpp"

#include <algorithm>
#include <cmath>

#include "core/error.hpp"

namespace bsdfmix {

namespace {

// An orthonormal pair perpendicular to the unit vector n (Duff et al. 2017).
void basis(const Vec3& n, Vec3& t1, Vec3& t2) {
  const double s = std::copysign(1.0, n[2]);
  const double a = -1.0 / (s + n[2]), b = n[0] * n[1] * a;
  t1 = {1 + s * n[0] * n[0] * a, s * b, -s * n[0]};
  t2 = {b, s + n[1] * n[1] * a, -n[1]};
}

// First i in [0, n) with cdf[i + 1] > u (cdf[0] = 0, cdf[n] = 1).
std::size_t find(const double* cdf, std::size_t n, double u) {
  std::size_t lo = 0, hi = n;
  while (lo < hi) {
    const std::size_t mid = (lo + hi) / 2;
    if (cdf[mid + 1] > u) hi = mid;
    else lo = mid + 1;
  }
  return std::min(lo, n - 1);
}

// t in [0, 1] with density proportional to a + (b - a) t, from u in [0, 1) (a, b >= 0,
// not both 0): the root of a t + (b - a) t^2 / 2 = u (a + b) / 2, in the form stable at a = b.
double linear_draw(double a, double b, double u) {
  const double r = std::sqrt(std::max(a * a + u * (b * b - a * a), 0.0));
  return a + r > 0 ? std::clamp(u * (a + b) / (a + r), 0.0, 1.0) : u;
}

double gradient_value(const Lighting& l, double t) {
  return t >= 0 ? l.horizon + (l.zenith - l.horizon) * t : l.horizon + (l.horizon - l.ground) * t;
}

}  // namespace

void world_to_slice(const Lighting& light, const Vec3& w, double& theta, double& phi) {
  const double a = std::clamp(dot(w, light.axis), -1.0, 1.0);
  theta = light.domain == Domain::Fiber ? std::asin(a) : std::acos(a);
  phi = std::atan2(dot(w, light.e2), dot(w, light.e1));
  phi = wrap_phi(phi);
}

LightSampler make_light_sampler(const Lighting& l) {
  LightSampler s;
  if (l.lobes.size() > Lighting::kMaxLobes) throw ConfigError("scene '" + l.name + "': more than 8 lobes");
  const std::string where = "scene '" + l.name + "'";
  if (l.constant < 0) throw ConfigError(where + ": the constant radiance is negative");
  const double p_const = 4 * kPi * l.constant;
  double p_grad = 0;
  if (l.gradient) {
    if (l.zenith < 0 || l.horizon < 0 || l.ground < 0)
      throw ConfigError(where + ": a gradient value is negative (light sampling needs L >= 0)");
    const double neg = 0.5 * (l.ground + l.horizon), pos = 0.5 * (l.horizon + l.zenith);
    s.grad_g = neg + pos;
    s.grad_neg = s.grad_g > 0 ? neg / s.grad_g : 0;
    p_grad = 2 * kPi * s.grad_g;
    basis(l.up, s.up_t1, s.up_t2);
  }
  std::vector<double> p_lobe;
  for (const LightLobe& lb : l.lobes) {
    if (lb.radiance < 0) throw ConfigError(where + ": a lobe's radiance is negative");
    const double k = lb.kappa;
    const double mass = 2 * kPi * (k > 1e-8 ? -std::expm1(-2 * k) / k : 2.0);  // integral of exp(k (cos - 1))
    p_lobe.push_back(lb.radiance * mass);
    s.lobe_norm.push_back(1.0 / mass);
    Vec3 t1, t2;
    basis(lb.direction, t1, t2);
    s.lobe_t1.push_back(t1);
    s.lobe_t2.push_back(t2);
  }
  double p_env = 0;
  if (l.env_scale != 0 && l.env_width > 0) {
    if (l.env_scale < 0) throw ConfigError(where + ": the environment map's scale is negative");
    const int W = l.env_width, H = l.env_height;
    s.env_w = W;
    s.env_h = H;
    // Each pixel's weight: the largest value of its 3 x 3 neighbourhood (the bilinear
    // lookup inside a pixel mixes only those), so the density is positive wherever L is.
    std::vector<double> v(std::size_t(W) * std::size_t(H));
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x) {
        double m = 0;
        for (int dy = -1; dy <= 1; ++dy)
          for (int dx = -1; dx <= 1; ++dx) {
            const int yy = std::clamp(y + dy, 0, H - 1), xx = ((x + dx) % W + W) % W;
            m = std::max(m, double(l.env[std::size_t(yy) * std::size_t(W) + std::size_t(xx)]));
          }
        if (m < 0) throw ConfigError(where + ": the environment map has negative pixels");
        v[std::size_t(y) * std::size_t(W) + std::size_t(x)] = l.env_scale * m;
      }
    s.env_marginal.assign(std::size_t(H) + 1, 0.0);
    s.env_conditional.assign(std::size_t(H) * std::size_t(W + 1), 0.0);
    s.env_density.assign(std::size_t(H) * std::size_t(W), 0.0);
    std::vector<double> row_power(std::size_t(H), 0.0);
    for (int y = 0; y < H; ++y) {
      const double omega = (std::cos(kPi * y / H) - std::cos(kPi * (y + 1) / H)) * 2 * kPi / W;
      double* c = &s.env_conditional[std::size_t(y) * std::size_t(W + 1)];
      double acc = 0;
      for (int x = 0; x < W; ++x) {
        acc += v[std::size_t(y) * std::size_t(W) + std::size_t(x)] * omega;
        c[x + 1] = acc;
      }
      for (int x = 0; x <= W; ++x) c[x] = acc > 0 ? c[x] / acc : double(x) / W;
      c[W] = 1;
      row_power[std::size_t(y)] = acc;
      p_env += acc;
    }
    if (p_env > 0) {
      double acc = 0;
      for (int y = 0; y < H; ++y) {
        acc += row_power[std::size_t(y)];
        s.env_marginal[std::size_t(y) + 1] = acc / p_env;
        for (int x = 0; x < W; ++x)
          s.env_density[std::size_t(y) * std::size_t(W) + std::size_t(x)] =
              v[std::size_t(y) * std::size_t(W) + std::size_t(x)] / p_env;
      }
      s.env_marginal[std::size_t(H)] = 1;
    }
  }
  double total = p_const + p_grad + p_env;
  for (const double p : p_lobe) total += p;
  if (!(total > 0) || !std::isfinite(total)) throw ConfigError(where + ": the lighting has no power to sample");
  s.p_const = p_const / total;
  s.p_grad = p_grad / total;
  s.p_env = p_env / total;
  for (const double p : p_lobe) s.p_lobe.push_back(p / total);
  s.light = l;
  return s;
}

Vec3 LightSampler::sample(double u0, double u1, double u2, double u3) const {
  const Lighting& l = light;
  // The term: the first whose cumulative probability passes u0; rounding can leave the
  // sum a little below 1, and a u0 past it goes to the last term present.
  const std::size_t terms = 3 + p_lobe.size();
  auto prob = [&](std::size_t k) { return k == 0 ? p_const : k == 1 ? p_grad : k == 2 ? p_env : p_lobe[k - 3]; };
  std::size_t term = terms;
  double acc = 0;
  for (std::size_t k = 0; k < terms && term == terms; ++k) {
    acc += prob(k);
    if (u0 < acc && prob(k) > 0) term = k;
  }
  if (term == terms)
    for (std::size_t k = terms; k-- > 0;)
      if (prob(k) > 0) {
        term = k;
        break;
      }
  if (term == 0 || term == terms) {  // the uniform sphere
    const double z = 1 - 2 * u2, r = std::sqrt(std::max(0.0, 1 - z * z));
    return {r * std::cos(2 * kPi * u3), r * std::sin(2 * kPi * u3), z};
  }
  if (term == 1) {  // t = dot(w, up) by the gradient's piecewise linear density
    double t;
    if (u1 < grad_neg) t = -linear_draw(l.horizon, l.ground, u2);
    else t = linear_draw(l.horizon, l.zenith, u2);
    const double r = std::sqrt(std::max(0.0, 1 - t * t)), c = std::cos(2 * kPi * u3), s = std::sin(2 * kPi * u3);
    Vec3 w;
    for (int i = 0; i < 3; ++i) w[i] = t * l.up[i] + r * (c * up_t1[i] + s * up_t2[i]);
    return w;
  }
  if (term == 2) {  // a pixel by the 2D distribution, then uniform in solid angle inside it
    const std::size_t W = std::size_t(env_w), H = std::size_t(env_h);
    const std::size_t y = find(env_marginal.data(), H, u1);
    const double* c = &env_conditional[y * (W + 1)];
    const std::size_t x = find(c, W, u2);
    const double fx = std::clamp((u2 - c[x]) / std::max(c[x + 1] - c[x], 1e-300), 0.0, 1.0);
    const double za = std::cos(kPi * double(y) / double(H)), zb = std::cos(kPi * double(y + 1) / double(H));
    const double z = za + u3 * (zb - za), r = std::sqrt(std::max(0.0, 1 - z * z));
    const double az = -kPi + 2 * kPi * (double(x) + fx) / double(W);
    return {r * std::cos(az), r * std::sin(az), z};
  }
  // a lobe: 1 - cos by the exact inverse of the von Mises-Fisher distribution
  const std::size_t k = term - 3;
  const LightLobe& lb = l.lobes[k];
  const double u = 1 - u1;  // (0, 1]
  const double omc = std::min(2.0, -std::log(u + (1 - u) * std::exp(-2 * lb.kappa)) / lb.kappa);
  const double st = std::sqrt(std::max(0.0, omc * (2 - omc))), ct = 1 - omc;
  const double c = std::cos(2 * kPi * u2), s = std::sin(2 * kPi * u2);
  Vec3 w;
  for (int i = 0; i < 3; ++i) w[i] = ct * lb.direction[i] + st * (c * lobe_t1[k][i] + s * lobe_t2[k][i]);
  (void)u3;
  return w;
}

double LightSampler::pdf(const Vec3& w) const {
  const Lighting& l = light;
  double p = p_const / (4 * kPi);
  if (p_grad > 0) p += p_grad * gradient_value(l, dot(w, l.up)) / (2 * kPi * grad_g);
  if (p_env > 0) {
    const int x = std::clamp(int(std::floor((std::atan2(w[1], w[0]) + kPi) / (2 * kPi) * env_w)), 0, env_w - 1);
    const int y = std::clamp(int(std::floor(std::acos(std::clamp(w[2], -1.0, 1.0)) / kPi * env_h)), 0, env_h - 1);
    p += p_env * env_density[std::size_t(y) * std::size_t(env_w) + std::size_t(x)];
  }
  for (std::size_t k = 0; k < p_lobe.size(); ++k) {
    const LightLobe& lb = l.lobes[k];
    double d2 = 0;
    for (int i = 0; i < 3; ++i) d2 += (w[i] - lb.direction[i]) * (w[i] - lb.direction[i]);
    p += p_lobe[k] * lobe_norm[k] * std::exp(-0.5 * lb.kappa * d2);
  }
  return p;
}

std::vector<float> LightSampler::pack() const {
  std::vector<float> p(kHeader, 0.f);
  p[0] = float(p_const);
  p[1] = float(p_grad);
  p[2] = float(p_env);
  p[3] = float(p_lobe.size());
  p[4] = float(grad_g);
  p[5] = float(grad_neg);
  p[6] = float(env_w);
  p[7] = float(env_h);
  for (std::size_t k = 0; k < p_lobe.size(); ++k) {
    p[8 + k] = float(p_lobe[k]);
    p[16 + k] = float(lobe_norm[k]);
    for (std::size_t i = 0; i < 3; ++i) {
      p[24 + 6 * k + i] = float(lobe_t1[k][i]);
      p[27 + 6 * k + i] = float(lobe_t2[k][i]);
    }
  }
  for (std::size_t i = 0; i < 3; ++i) {
    p[72 + i] = float(up_t1[i]);
    p[75 + i] = float(up_t2[i]);
  }
  int last = 0;
  for (std::size_t k = 0; k < 3 + p_lobe.size(); ++k)
    if ((k == 0 ? p_const : k == 1 ? p_grad : k == 2 ? p_env : p_lobe[k - 3]) > 0) last = int(k);
  p[78] = float(last);
  for (const double v : env_marginal) p.push_back(float(v));
  for (const double v : env_conditional) p.push_back(float(v));
  for (const double v : env_density) p.push_back(float(v));
  return p;
}

}  // namespace bsdfmix
