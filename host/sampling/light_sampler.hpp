// Light sampling, as a renderer samples its lights: each term of a scene's lighting
// (host/sampling/lighting.hpp) by its own density, the term chosen in proportion to its
// power. The constant by the uniform sphere; a lobe radiance * exp(kappa (cos - 1)) exactly
// (the von Mises-Fisher distribution); the gradient by its piecewise linear density in
// dot(w, up); the environment map by a piecewise-constant 2D distribution over its pixels
// (pbrt-v4's ImageInfiniteLight), uniform in solid angle inside a pixel. The densities are
// per steradian over the whole sphere; the estimators convert to the slice's (theta, phi)
// with its Jacobian and drop directions outside the table's domain. kernels/sample.cl
// (light_draw, light_pdf) runs the same sampler on pack().
#pragma once

#include <cstddef>
#include <vector>

#include "sampling/lighting.hpp"

namespace bsdfmix {

struct LightSampler {
  Lighting light;  // what is sampled (its lobes, gradient and frame)
  // Probabilities of the terms: constant, gradient, environment map, lobes.
  double p_const = 0, p_grad = 0, p_env = 0;
  std::vector<double> p_lobe;
  std::vector<double> lobe_norm;    // 1 / the integral of exp(kappa (cos - 1)): the lobe's density at its peak
  std::vector<Vec3> lobe_t1, lobe_t2;  // an orthonormal basis around each lobe's direction
  // The gradient's density in t = dot(w, up): g(t) / (2 pi G), G = integral of g over [-1, 1].
  double grad_g = 0, grad_neg = 0;  // G, and the share of it below the horizon
  Vec3 up_t1{1, 0, 0}, up_t2{0, 1, 0};
  // The map's pixel distribution: marginal over rows [H + 1], conditional per row
  // [H][W + 1], and the density per steradian inside each pixel [H][W] (given the map term).
  int env_w = 0, env_h = 0;
  std::vector<double> env_marginal, env_conditional, env_density;

  // A direction (world, unit) from four uniforms: u0 picks the term, u1..u3 the point.
  Vec3 sample(double u0, double u1, double u2, double u3) const;
  // The density per steradian of what sample() returns.
  double pdf(const Vec3& w) const;

  static constexpr std::size_t kHeader = 128;  // floats before the map's arrays in pack()
  std::vector<float> pack() const;            // kernels/sample.cl light layout (LS_*)
};

// Throws ConfigError when the lighting has no power or a negative term.
LightSampler make_light_sampler(const Lighting& light);

// World direction to the table's (theta, phi) in the lighting's frame, and back.
void world_to_slice(const Lighting& light, const Vec3& w, double& theta, double& phi);

}  // namespace bsdfmix
