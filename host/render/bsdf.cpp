// The BSDFs at a path vertex: a fiber, a measured surface, the Lambertian ground.
#include "render/bsdf.hpp"

#include <algorithm>
#include <cmath>

#include "render/full_f.hpp"

namespace bsdfmix {
namespace render {

template <>
FiberBsdf::TabulatedBsdf(const SampledBxdf& bxdf, const Vec3& axis, const Vec3& wo)
    : bxdf_(&bxdf), frame_(axis, wo, Domain::Fiber), full_(bxdf.full()) {
  if (full_) phi_o_ = reference_phi(frame_.a.axis, wo);
}

template <>
SurfaceBsdf::TabulatedBsdf(const SampledBxdf& bxdf, const Vec3& axis, const Vec3& wo)
    : bxdf_(&bxdf), frame_(axis, wo, Domain::Hemisphere) {}

template <>
Rgb FiberBsdf::f(const Vec3& wi) const {
  double th, ph;
  frame_.to_local(wi, th, ph);
  // the full-4D table's phi is about the reference e1; the frame's from omega_o's plane
  if (full_) return Rgb(full_->f(bxdf_->source(), frame_.theta_o, phi_o_, th, wrap_phi(ph + phi_o_)));
  return bxdf_->f(frame_.theta_o, th, ph);
}

template <>
Rgb SurfaceBsdf::f(const Vec3& wi) const {
  double th, ph;
  frame_.to_local(wi, th, ph);
  return th < kPi / 2 ? bxdf_->f(frame_.theta_o, th, ph) * std::cos(th) : Rgb();
}

Lambertian::Lambertian(double albedo, const Vec3& normal) : albedo_(albedo), n_(normal) {
  t1_ = normalized(std::abs(n_[0]) < 0.9 ? cross(n_, {1, 0, 0}) : cross(n_, {0, 1, 0}));
  t2_ = cross(n_, t1_);
}

Rgb Lambertian::f(const Vec3& wi) const {
  const double c = dot(wi, n_);
  return Rgb(c > 0 ? albedo_ / kPi * c : 0.0);
}

double Lambertian::pdf(const Vec3& wi) const {
  const double c = dot(wi, n_);
  return c > 0 ? c / kPi : 0.0;
}

bool Lambertian::sample(const double u[4], Vec3& wi, double& pdf) const {
  const double r = std::sqrt(u[2]), a = 2 * kPi * u[3];
  const double x = r * std::cos(a), y = r * std::sin(a), z = std::sqrt(std::max(0.0, 1 - u[2]));
  for (int i = 0; i < 3; ++i) wi[i] = x * t1_[i] + y * t2_[i] + z * n_[i];
  pdf = z / kPi;
  return pdf > 0;
}

const Bsdf& VertexBsdf::at(const Hit& hit, const Vec3& wo, const SampledBxdf& material, double albedo) {
  switch (hit.kind) {
    case HitKind::Fiber: return held_.emplace<FiberBsdf>(material, hit.tangent, wo);
    case HitKind::Surface: return held_.emplace<SurfaceBsdf>(material, hit.normal, wo);
    default: return held_.emplace<Lambertian>(albedo, hit.normal);
  }
}

}  // namespace render
}  // namespace bsdfmix
