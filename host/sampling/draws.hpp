// The draws and densities the study's estimators combine (host/sampling/estimator_*.cpp):
// uniform over the domain, the table's CDF, the light sampler, the RGL file's warps, and
// one-sample MIS over techniques picked by their fractions.
#pragma once

#include <algorithm>
#include <cmath>

#include "sampling/sampling.hpp"

namespace bsdfmix {
namespace draws {

// Uniform direction over the domain (pdf 1/(4 pi) fiber, 1/(2 pi) hemisphere).
inline void uniform_draw(Domain d, double u, double v, double& theta, double& phi) {
  theta = d == Domain::Hemisphere ? std::acos(1.0 - u) : std::asin(std::clamp(2 * u - 1, -1.0, 1.0));
  phi = 2 * kPi * v - kPi;
}
inline double uniform_pdf(Domain d) { return d == Domain::Hemisphere ? 1 / (2 * kPi) : 1 / (4 * kPi); }
inline double cos_factor(Domain d, double theta) { return d == Domain::Hemisphere ? std::cos(theta) : 1.0; }
inline bool inside(Domain d, double theta) { return theta >= theta_lo(d) && theta <= theta_hi(d); }

// The table CDF's draw: cell by the 2D CDF, theta inside it with density c J, phi uniform.
bool cdf_draw(const Problem& p, double u0, double u1, double u2, double u3, double& th, double& ph);
// Its density per steradian: P_cell c(theta) / integral over the cell of c J.
double cdf_pdf(const Problem& p, double th, double ph);

double light_pdf(const Problem& p, double th, double ph);
void light_draw(const Problem& p, double u0, double u1, double u2, double u3, double& th, double& ph);

// The RGL file's warps in the table's frame: the view omega_o at phi = 0 of the slice
// frame (where the importer puts it), the light direction rotated into the world frame by
// the table's rotation (phi_o under azimuthal symmetry), as TableSlice::f_at reads it.
// Draws with u1, u2 (the file's two uniforms); false below the horizon.
bool rgl_draw(const Problem& p, double u1, double u2, double& th, double& ph, double* pdf = nullptr);
double rgl_pdf(const Problem& p, double th, double ph);

// f of the table and of the stand-in at (th, ph) (world phi).
using FOf = double (*)(const Problem& p, double th, double ph);
inline double table_f(const Problem& p, double th, double ph) { return p.table.f_at(th, ph); }
inline double stand_in_f(const Problem& p, double th, double ph) { return p.set->eval_f(p.theta_o, p.phi_o, th, ph); }

// Uniform sampling with f: one estimate, the density, the draw (StudyStrategy's).
double uniform_estimate(const Problem& p, const double u[4], FOf f);
double uniform_density(const Problem& p, double th, double ph);
bool uniform_direction(const Problem& p, const double u[4], double& th, double& ph);
// The mixture's own sampler (MixtureSet::sample, pdf_omega) with f.
double mixture_estimate(const Problem& p, const double u[4], FOf f);
double mixture_density(const Problem& p, double th, double ph);
bool mixture_direction(const Problem& p, const double u[4], double& th, double& ph);

// L_i f c / pdf at a drawn direction with the table's f; 0 where f or the density is.
inline double table_weight(const Problem& p, double th, double ph, double pdf) {
  const double f = p.table.f_at(th, ph);
  if (f == 0 || !(pdf > 0)) return 0;
  return p.light.radiance(th, ph) * f * cos_factor(p.table.domain, th) / pdf;
}

// A technique of one-sample MIS: its draw from (r0, u[1..3]) (false: none) and its density
// per steradian (0 outside the domain).
struct Technique {
  bool (*draw)(const Problem& p, double r0, const double u[4], double& th, double& ph);
  double (*pdf)(const Problem& p, double th, double ph);
};
extern const Technique kLightTechnique;    // the light sampler
extern const Technique kUniformTechnique;  // uniform over the domain
extern const Technique kCdfTechnique;      // the table's CDF
extern const Technique kMixtureTechnique;  // the mixture's own sampler
extern const Technique kProductTechnique;  // the product of the mixture and the lighting's
extern const Technique kRglTechnique;      // the RGL file's warps

// One-sample MIS (docs/sampling.md, "Sampling with the lighting"): techniques with
// fractions c[k], the point drawn by one of them picked by u0 (its remainder reused as the
// technique's u0), weighted by the balance or the power heuristic, f the table's.
struct MisTechniques {
  int n = 0;
  double c[3] = {0, 0, 0};
  const Technique* t[3] = {nullptr, nullptr, nullptr};
};
double mis_estimate(const Problem& p, const MisTechniques& t, const double u[4]);
// The combined density: sum of c[k] pdf[k].
double mis_pdf(const Problem& p, const MisTechniques& t, double th, double ph);
// The two as StudyStrategy's estimate and pdf of the techniques T gives a problem.
template <MisTechniques (*T)(const Problem&)>
double mis_estimate_of(const Problem& p, const double u[4]) {
  return mis_estimate(p, T(p), u);
}
template <MisTechniques (*T)(const Problem&)>
double mis_pdf_of(const Problem& p, double th, double ph) {
  return mis_pdf(p, T(p), th, ph);
}

}  // namespace draws
}  // namespace bsdfmix
