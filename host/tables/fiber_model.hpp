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
//
// Colour: the absorption sigma_a has one value per channel of linear RGB in Rec. 709 / sRGB
// primaries. The geometry (M_p, N_p, Fresnel, the internal path lengths) is shared; only
// the transmittance T = exp(-sigma_a * path) of the attenuations A_1..A_3 differs per
// channel. Every function below gives the three channels; `f` gives their luminance Y.
#pragma once

#include <array>
#include <cstddef>
#include <vector>

namespace bsdfmix {

// Channels of the model: R, G, B (linear, Rec. 709 / sRGB primaries).
constexpr int kFiberChannels = 3;
using FiberRgb = std::array<double, kFiberChannels>;

// The same value in every channel (a grey absorption, or a scalar sigma_a given by a user).
inline FiberRgb fiber_grey(double x) { return {x, x, x}; }

// Physical parameters of the model; angles in radians.
struct FiberParams {
  double eta = 1.55;               // refractive index of the fiber
  FiberRgb sigma_a{0.0, 0.0, 0.0};  // absorption coefficient per unit fiber radius, per channel (R, G, B)
  double beta_m = 0.3;             // longitudinal roughness in [0, 1]
  double beta_n = 0.3;   // azimuthal roughness in [0, 1]
  double alpha = 0.0;    // cuticle scale tilt, radians
};

// Number of lobes evaluated: R, TT, TRT and the residual.
constexpr int kFiberLobes = 4;
using FiberLobes = std::array<double, kFiberLobes>;

// The absorption that gives a fiber assembly the colour `color` (each channel in (0, 1],
// linear RGB) at azimuthal roughness beta_n: Chiang et al. 2016, section 4.2 (pbrt's
// SigmaAFromReflectance), per channel
//     sigma_a = (ln C / (5.969 - 0.215 b + 2.532 b^2 - 10.73 b^3 + 5.574 b^4 + 0.245 b^5))^2.
// C = 1 gives 0. Throws ConfigError for a channel outside (0, 1] or beta_n outside (0, 1].
FiberRgb sigma_a_from_color(const FiberRgb& color, double beta_n);

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
  // Throws ConfigError when a parameter is out of range (eta <= 1, a sigma_a channel < 0,
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

  // Attenuations A_0..A_3 at offset h for outgoing longitudinal angle theta_o, per channel
  // ([c][p]; A_0 = F is the same in every channel).
  std::array<FiberLobes, kFiberChannels> attenuation(double theta_o, double h) const;

  // Azimuthal lobe N_p(phi) at offset h (p = 0, 1, 2: trimmed logistic around
  // Phi(p, h); p = 3: 1 / (2 pi)); phi = phi_i - phi_o, any value (wrapped).
  double azimuthal(int p, double theta_o, double h, double phi) const;

  // f at one offset h (no averaging), per channel: sum_p M_p A_p N_p.
  FiberRgb f_at_h(double theta_o, double phi_o, double theta_i, double phi_i, double h) const;

  // f averaged over h by the Gauss-Legendre rule of this model, per channel: the table's
  // `rgb`.
  FiberRgb f_rgb(double theta_o, double phi_o, double theta_i, double phi_i) const;

  // The luminance Y of f_rgb (core/color.hpp): the table's `values`.
  double f(double theta_o, double phi_o, double theta_i, double phi_i) const;

  // The h-averaged azimuthal factors of a slice: out[c][p][j] = (1/2) sum_k w_k A_p(h_k)
  // N_p(phi_j; h_k) in channel c for the given phi differences (p = 3 includes 1 / (2 pi)),
  // so that f_c(theta_i, phi_j) = sum_p M_p(theta_o, theta_i) out[c][p][j].
  using AzimuthalFactors = std::array<std::array<std::vector<double>, kFiberLobes>, kFiberChannels>;
  AzimuthalFactors azimuthal_factors(double theta_o, const std::vector<double>& phi) const;

 private:
  FiberParams params_;
  std::array<double, kFiberLobes> v_{};
  double s_ = 0;
  std::array<double, 3> sin2k_{}, cos2k_{};  // sin/cos of 2^k alpha, k = 0, 1, 2
  GaussLegendre gl_;
};

}  // namespace bsdfmix
