// Slice grids and their validation.
#include "fit/slices.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "core/error.hpp"

namespace bsdfmix {

SliceGrid make_slice_grid(Domain domain, std::size_t n_theta, std::size_t n_phi) {
  SliceGrid g;
  g.domain = domain;
  g.theta = uniform_centers(theta_lo(domain), theta_hi(domain), n_theta);
  g.phi = uniform_centers(-kPi, kPi, n_phi);
  return g;
}

double plane_step(const SliceGrid& g) { return std::min(axis_step(g.theta), axis_step(g.phi)); }

namespace {
void check_uniform(const std::vector<double>& axis, const char* name) {
  if (axis.empty()) throw InputError(std::string("slice grid: the ") + name + " axis is empty");
  if (axis.size() < 2) return;
  const double step = axis_step(axis);
  if (!(step > 0)) throw InputError(std::string("slice grid: the ") + name + " axis is not increasing");
  for (std::size_t i = 1; i < axis.size(); ++i)
    if (std::abs(axis[i] - axis[i - 1] - step) > 1e-6 * step)
      throw InputError(std::string("slice grid: the ") + name + " axis is not uniform at index " +
                       std::to_string(i));
}
}  // namespace

void validate_slices(const SliceSet& set) {
  const SliceGrid& g = set.grid;
  check_uniform(g.theta, "theta");
  check_uniform(g.phi, "phi");
  const double period = axis_step(g.phi) * static_cast<double>(g.phi.size());
  if (g.phi.size() >= 2 && std::abs(period - 2 * kPi) > 1e-6)
    throw InputError("slice grid: the phi axis covers " + std::to_string(period) +
                     " rad, not one full period (2 pi)");
  if (g.cells() >= (std::size_t(1) << 24))
    throw InputError("slice grid: " + std::to_string(g.cells()) + " cells per slice, at most 2^24 supported");
  for (std::size_t s = 0; s < set.weights.size(); ++s) {
    const auto& w = set.weights[s];
    if (w.size() != g.cells())
      throw InputError("slice " + std::to_string(s) + ": " + std::to_string(w.size()) +
                       " weights for a grid of " + std::to_string(g.cells()) + " cells");
    for (std::size_t i = 0; i < w.size(); ++i)
      if (!std::isfinite(w[i]) || w[i] < 0)
        throw InputError("slice " + std::to_string(s) + ": weight of cell " + std::to_string(i) +
                         " is " + std::to_string(w[i]) + " (must be finite and non-negative)");
  }
}

}  // namespace bsdfmix
