// The fiber scattering model of Chiang et al. 2016 ("A Practical and Controllable Hair
// and Fur Model for Production Path Tracing"), as pbrt-v4's HairBxDF evaluates it, in
// double precision: the CPU reference of kernels/fiber.cl (docs/fiber.md).
//
// Conventions (docs/formats.md, "Angular conventions", domain `fiber`): theta in
// [-pi/2, pi/2] with sin(theta) = dot(omega, tangent), phi the azimuth around the fiber
// axis. Our f is the far-field BCSDF summed over the lobes p = 0 (R), 1 (TT), 2 (TRT)
// and the residual p = 3,
//     f(omega_o, omega_i) = (1/2) integral_{-1}^{1} sum_p M_p A_p N_p dh,
// i.e. pbrt's HairBxDF::f times |cos theta_i| in its shading frame, averaged over the
// offset h. With that, L_o = integral L_i f d(omega_i), d(omega) = cos(theta) dtheta dphi,
// and the lossless model integrates to 1 over the sphere for every omega_o.
#pragma once

#include <array>
#include <cstddef>
#include <vector>

namespace bsdfmix {

// Physical parameters of the model; angles in radians.
struct FiberParams {
  double eta = 1.55;     // refractive index of the fiber
  double sigma_a = 0.0;  // absorption coefficient per unit fiber radius (scalar, luminance-like)
  double beta_m = 0.3;   // longitudinal roughness in [0, 1]
  double beta_n = 0.3;   // azimuthal roughness in [0, 1]
  double alpha = 0.0;    // cuticle scale tilt, radians
};

// Number of lobes evaluated: R, TT, TRT and the residual.
constexpr int kFiberLobes = 4;

// Gauss-Legendre quadrature on [-1, 1]: n nodes (ascending) and weights (summing to 2).
struct GaussLegendre {
  std::vector<double> nodes, weights;
};
GaussLegendre gauss_legendre(std::size_t n);

// The default number of Gauss-Legendre nodes in h (docs/fiber.md, "Quadrature in h").
constexpr std::size_t kFiberHNodes = 256;

// Modified Bessel function of the first kind, order 0, and its logarithm (x >= 0),
// accurate to about 1e-12 relative.
double bessel_i0(double x);
double log_bessel_i0(double x);

// Derived per-lobe quantities of a parameter set, computed once.
class FiberModel {
 public:
  // Throws ConfigError when a parameter is out of range (eta <= 1, sigma_a < 0,
  // beta outside (0, 1], |alpha| >= pi/4), naming `where`.
  explicit FiberModel(const FiberParams& params, std::size_t h_nodes = kFiberHNodes,
                      const char* where = "fiber model");

  const FiberParams& params() const { return params_; }
  double variance(int p) const { return v_[static_cast<std::size_t>(p)]; }  // longitudinal v_p
  double logistic_scale() const { return s_; }                            // azimuthal s
  const GaussLegendre& h_quadrature() const { return gl_; }

  // Longitudinal lobe M_p(theta_o, theta_i) with the scale tilt of lobe p applied to theta_o
  // (p = 0: -2 alpha, p = 1: +alpha, p = 2: +4 alpha, p = 3: none), computed as pbrt does
  // through sin/cos of 2^k alpha and |cos theta_o'|. Normalized: integral M_p cos(theta_i)
  // dtheta_i = 1 over [-pi/2, pi/2] for every theta_o.
  double longitudinal(int p, double theta_o, double theta_i) const;

  // Attenuations A_0..A_3 at offset h for outgoing longitudinal angle theta_o.
  std::array<double, kFiberLobes> attenuation(double theta_o, double h) const;

  // Azimuthal lobe N_p(phi) at offset h (p = 0, 1, 2: trimmed logistic around
  // Phi(p, h); p = 3: 1 / (2 pi)); phi = phi_i - phi_o, any value (wrapped).
  double azimuthal(int p, double theta_o, double h, double phi) const;

  // f at one offset h (no averaging): sum_p M_p A_p N_p.
  double f_at_h(double theta_o, double phi_o, double theta_i, double phi_i, double h) const;

  // f averaged over h by the Gauss-Legendre rule of this model: the table's value.
  double f(double theta_o, double phi_o, double theta_i, double phi_i) const;

  // The h-averaged azimuthal factors of a slice: out[p][j] = (1/2) sum_k w_k A_p(h_k)
  // N_p(phi_j; h_k) for the given phi differences (p = 3 includes 1 / (2 pi)), so that
  // f(theta_i, phi_j) = sum_p M_p(theta_o, theta_i) out[p][j].
  std::array<std::vector<double>, kFiberLobes> azimuthal_factors(double theta_o,
                                                                 const std::vector<double>& phi) const;

 private:
  FiberParams params_;
  std::array<double, kFiberLobes> v_{};
  double s_ = 0;
  std::array<double, 3> sin2k_{}, cos2k_{};  // sin/cos of 2^k alpha, k = 0, 1, 2
  GaussLegendre gl_;
};

}  // namespace bsdfmix
