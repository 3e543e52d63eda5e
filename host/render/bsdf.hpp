// The BSDF at a path vertex, in world directions (pbrt-v4's BSDF: a BxDF in the hit's
// shading frame): at a fiber the BCSDF of render/bxdf.hpp in the fiber's frame (L_o =
// integral L_i f), at a measured surface its BRDF in the frame of the shading normal with
// the cosine (f cos(theta_i), the upper hemisphere), at the ground (and the room) a
// Lambertian of the scene's albedo. The path tracer asks the vertex's Bsdf for the
// integrand's factor, a direction and its density, never which material it hit.
#pragma once

#include <variant>

#include "render/bxdf.hpp"
#include "render/local_axes.hpp"
#include "render/tracer.hpp"

namespace bsdfmix {
namespace render {

class Bsdf {
 public:
  virtual ~Bsdf() = default;
  // The integrand's factor per channel toward wi (f, times the cosine on a surface).
  virtual Rgb f(const Vec3& wi) const = 0;
  // The density per steradian with which sample() draws wi.
  virtual double pdf(const Vec3& wi) const = 0;
  // A direction from u[0..3] and its density; false: none.
  virtual bool sample(const double u[4], Vec3& wi, double& pdf) const = 0;
  // A tabulated material (a fiber, a measured surface): the products of render/fast_product.hpp
  // and the guide are built in its frame at its theta_o. The ground has none.
  virtual bool tabulated() const { return false; }
  virtual LocalAxes axes() const { return {}; }
  virtual double theta_o() const { return 0; }
};

// A tabulated material: the BxDF in the hit's frame. FiberBsdf: a fiber's frame (tangent,
// the plane of omega_o), f as it is. SurfaceBsdf: a measured surface's (the shading
// normal), f cos(theta_i) over the upper hemisphere.
template <Domain D>
class TabulatedBsdf : public Bsdf {
 public:
  TabulatedBsdf(const SampledBxdf& bxdf, const Vec3& axis, const Vec3& wo);
  Rgb f(const Vec3& wi) const override;
  double pdf(const Vec3& wi) const override {
    double th, ph;
    frame_.to_local(wi, th, ph);
    return bxdf_->pdf(frame_.theta_o, th, ph);
  }
  bool sample(const double u[4], Vec3& wi, double& pdf) const override {
    double th, ph;
    bxdf_->sample(frame_.theta_o, u, th, ph, pdf);
    if (!(pdf > 0)) return false;
    wi = frame_.to_world(th, ph);
    return true;
  }
  bool tabulated() const override { return true; }
  LocalAxes axes() const override { return frame_.axes(); }
  double theta_o() const override { return frame_.theta_o; }

 private:
  const SampledBxdf* bxdf_;
  HitFrame frame_;
  const FullF* full_ = nullptr;  // a fiber's f from a full-4D table (render/full_f.hpp)
  double phi_o_ = 0;             // then omega_o's azimuth in the fiber's reference frame
};
using FiberBsdf = TabulatedBsdf<Domain::Fiber>;
using SurfaceBsdf = TabulatedBsdf<Domain::Hemisphere>;
template <>
FiberBsdf::TabulatedBsdf(const SampledBxdf& bxdf, const Vec3& axis, const Vec3& wo);
template <>
SurfaceBsdf::TabulatedBsdf(const SampledBxdf& bxdf, const Vec3& axis, const Vec3& wo);
template <>
Rgb FiberBsdf::f(const Vec3& wi) const;
template <>
Rgb SurfaceBsdf::f(const Vec3& wi) const;

// The ground and the room: albedo / pi cos+, drawn cosine-weighted about the normal.
class Lambertian : public Bsdf {
 public:
  Lambertian(double albedo, const Vec3& normal);
  Rgb f(const Vec3& wi) const override;
  double pdf(const Vec3& wi) const override;
  bool sample(const double u[4], Vec3& wi, double& pdf) const override;

 private:
  double albedo_;
  Vec3 n_, t1_, t2_;
};

// The Bsdf of a hit, held in place (no allocation per vertex).
class VertexBsdf {
 public:
  // `material` serves fibers and measured surfaces; the ground is a Lambertian of `albedo`.
  const Bsdf& at(const Hit& hit, const Vec3& wo, const SampledBxdf& material, double albedo);

 private:
  std::variant<std::monostate, FiberBsdf, SurfaceBsdf, Lambertian> held_;
};

}  // namespace render
}  // namespace bsdfmix
