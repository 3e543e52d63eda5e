// Lighting of a convergence scene: evaluation in double and packing for the kernels.
#include "sampling/lighting.hpp"

#include <algorithm>
#include <cmath>

#include "core/error.hpp"

namespace bsdfmix {

Vec3 Lighting::to_world(double theta, double phi) const {
  const double st = std::sin(theta), ct = std::cos(theta), cp = std::cos(phi), sp = std::sin(phi);
  const double a = domain == Domain::Fiber ? st : ct, r = domain == Domain::Fiber ? ct : st;
  Vec3 w;
  for (int i = 0; i < 3; ++i) w[i] = a * axis[i] + r * (cp * e1[i] + sp * e2[i]);
  return w;
}

double Lighting::radiance_world(const Vec3& w) const {
  double L = constant;
  for (const auto& lb : lobes) {
    double d2 = 0;
    for (int i = 0; i < 3; ++i) d2 += (w[i] - lb.direction[i]) * (w[i] - lb.direction[i]);
    L += lb.radiance * std::exp(-0.5 * lb.kappa * d2);
  }
  if (gradient) {
    const double t = dot(w, up);
    L += t >= 0 ? horizon + (zenith - horizon) * t : horizon + (horizon - ground) * t;
  }
  if (env_scale != 0 && env_width > 0) {
    const int W = env_width, H = env_height;
    const double u = (std::atan2(w[1], w[0]) + kPi) / (2 * kPi) * W - 0.5;
    const double v = std::acos(std::clamp(w[2], -1.0, 1.0)) / kPi * H - 0.5;
    const double fu = std::floor(u), fv = std::floor(v);
    const double au = u - fu, av = v - fv;
    int x0 = int(fu), y0 = int(fv), x1 = x0 + 1, y1 = y0 + 1;
    x0 = (x0 % W + W) % W;
    x1 = (x1 % W + W) % W;
    y0 = std::clamp(y0, 0, H - 1);
    y1 = std::clamp(y1, 0, H - 1);
    auto at = [&](int y, int x) { return double(env[std::size_t(y) * std::size_t(W) + std::size_t(x)]); };
    const double top = (1 - au) * at(y0, x0) + au * at(y0, x1);
    const double bot = (1 - au) * at(y1, x0) + au * at(y1, x1);
    L += env_scale * ((1 - av) * top + av * bot);
  }
  return L;
}

double Lighting::finest_feature() const {
  double f = kPi / 2;
  for (const auto& lb : lobes) f = std::min(f, 1.0 / std::sqrt(std::max(lb.kappa, 1e-12)));
  if (env_scale != 0 && env_height > 0) f = std::min(f, kPi / env_height);
  return f;
}

std::vector<float> Lighting::pack() const {
  std::vector<float> p(kPacked, 0.f);
  for (int i = 0; i < 3; ++i) {
    p[std::size_t(i)] = float(axis[std::size_t(i)]);
    p[std::size_t(3 + i)] = float(e1[std::size_t(i)]);
    p[std::size_t(6 + i)] = float(e2[std::size_t(i)]);
  }
  p[9] = float(constant);
  if (lobes.size() > kMaxLobes) throw ConfigError("scene '" + name + "': more than 8 lobes");
  p[10] = float(lobes.size());
  for (std::size_t i = 0; i < lobes.size(); ++i) {
    for (std::size_t k = 0; k < 3; ++k) p[11 + 5 * i + k] = float(lobes[i].direction[k]);
    p[11 + 5 * i + 3] = float(lobes[i].kappa);
    p[11 + 5 * i + 4] = float(lobes[i].radiance);
  }
  for (std::size_t k = 0; k < 3; ++k) p[51 + k] = float(up[k]);
  p[54] = float(zenith);
  p[55] = float(horizon);
  p[56] = float(ground);
  p[57] = gradient ? 1.f : 0.f;
  p[58] = float(env_width);
  p[59] = float(env_height);
  p[60] = env_width > 0 ? float(env_scale) : 0.f;
  return p;
}

Lighting default_lighting(Domain domain, double constant) {
  Lighting l;
  l.domain = domain;
  l.constant = constant;
  if (domain == Domain::Fiber) set_frame(l, {1, 0, 0}, {0, 0, 1}, "default frame");
  else set_frame(l, {0, 0, 1}, {1, 0, 0}, "default frame");
  return l;
}

void set_frame(Lighting& l, const Vec3& axis, const Vec3& phi0, const std::string& where) {
  const double na = std::sqrt(dot(axis, axis));
  if (!(na > 1e-9) || !std::isfinite(na)) throw ConfigError(where + ": the frame axis is zero or not finite");
  Vec3 a{axis[0] / na, axis[1] / na, axis[2] / na};
  const double d = dot(phi0, a);
  Vec3 e{phi0[0] - d * a[0], phi0[1] - d * a[1], phi0[2] - d * a[2]};
  const double ne = std::sqrt(dot(e, e));
  if (!(ne > 1e-6)) throw ConfigError(where + ": the phi = 0 direction is parallel to the frame axis");
  for (auto& x : e) x /= ne;
  l.axis = a;
  l.e1 = e;
  l.e2 = cross(a, e);
}

}  // namespace bsdfmix
