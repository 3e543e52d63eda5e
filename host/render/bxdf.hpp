// The renderer's BxDFs (pbrt-v4's BxDF: f, its own draw and that draw's density, in the
// local frame of a hit for omega_o at theta_o, phi from the plane of omega_o): the
// material's table (its f, drawn by its CDF), its mixture stand-in (the stand-in's f, drawn
// by the mixture with a defensive uniform share), the RGL file it was imported from (drawn
// by the file's warps; f the table's, which the import made of the file), and uniform
// sampling (f the table's). render/bsdf.hpp places them at a hit: a fiber's frame, a
// measured surface's, and the ground's Lambertian.
#pragma once

#include "core/color.hpp"
#include "render/table_bsdf.hpp"
#include "sampling/estimator.hpp"

namespace bsdfmix {
namespace render {

class Bxdf {
 public:
  virtual ~Bxdf() = default;
  virtual Rgb f(double theta_o, double theta, double phi) const = 0;
  // A direction from u[0..3] and its density per steradian; pdf 0: no sample.
  virtual void sample(double theta_o, const double u[4], double& theta, double& phi, double& pdf) const = 0;
  virtual double pdf(double theta_o, double theta, double phi) const = 0;
};

// A material's f with one of its techniques drawing (TableBsdf::f_rgb, sample and pdf).
class TechniqueBxdf : public Bxdf {
 public:
  TechniqueBxdf(const TableBsdf& m, FSource f, BsdfSampler s) : m_(&m), f_(f), s_(s) {}
  Rgb f(double theta_o, double theta, double phi) const override { return m_->f_rgb(f_, theta_o, theta, phi); }
  void sample(double theta_o, const double u[4], double& theta, double& phi, double& pdf) const override {
    m_->sample(s_, theta_o, u, theta, phi, pdf);
  }
  double pdf(double theta_o, double theta, double phi) const override { return m_->pdf(s_, theta_o, theta, phi); }

 private:
  const TableBsdf* m_;
  FSource f_;
  BsdfSampler s_;
};

// The table: its f, drawn by its CDF.
struct TableBxdf : TechniqueBxdf {
  explicit TableBxdf(const TableBsdf& m) : TechniqueBxdf(m, FSource::Table, BsdfSampler::TableCdf) {}
};
// The mixture stand-in: its f, drawn by the mixture (with TableBsdf::uniform_fraction uniform).
struct StandInBxdf : TechniqueBxdf {
  explicit StandInBxdf(const TableBsdf& m) : TechniqueBxdf(m, FSource::StandIn, BsdfSampler::Mixture) {}
};
// The RGL file the table was imported from (TableBsdf::set_rgl): drawn by its warps.
struct RglBxdf : TechniqueBxdf {
  explicit RglBxdf(const TableBsdf& m) : TechniqueBxdf(m, FSource::Table, BsdfSampler::Rgl) {}
};
// Uniform over the material's domain.
struct UniformBxdf : TechniqueBxdf {
  explicit UniformBxdf(const TableBsdf& m) : TechniqueBxdf(m, FSource::Table, BsdfSampler::Uniform) {}
};

// The BxDF a path vertex integrates: f of the table or of the stand-in, drawn as the
// estimator's strategy has it (sampling/estimator.hpp, PathStrategy): by the BxDF of its
// technique (uniform, the stand-in's mixture, the table's CDF, the RGL file's warps) or by
// its own VertexSampler.
class SampledBxdf : public Bxdf {
 public:
  SampledBxdf(const TableBsdf& m, FSource f, const PathStrategy& s);
  Rgb f(double theta_o, double theta, double phi) const override {
    return (f_ == FSource::Table ? table_.f(theta_o, theta, phi) : stand_in_.f(theta_o, theta, phi));
  }
  void sample(double theta_o, const double u[4], double& theta, double& phi, double& pdf) const override {
    if (own_) own_->sample(*m_, theta_o, u, theta, phi, pdf);
    else draw_->sample(theta_o, u, theta, phi, pdf);
  }
  double pdf(double theta_o, double theta, double phi) const override {
    return own_ ? own_->pdf(*m_, theta_o, theta, phi) : draw_->pdf(theta_o, theta, phi);
  }
  // Which f it integrates, and the full-4D table that gives it at fibers (nullptr: none).
  FSource source() const { return f_; }
  const FullF* full() const { return m_->full(); }

 private:
  const TableBsdf* m_;
  FSource f_;
  TableBxdf table_;
  StandInBxdf stand_in_;
  RglBxdf rgl_;
  UniformBxdf uniform_;
  const Bxdf* draw_ = nullptr;
  const VertexSampler* own_;
};

}  // namespace render
}  // namespace bsdfmix
