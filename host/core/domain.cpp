// Angular domains, cell grids, Jacobians and integrand weights.
#include "core/domain.hpp"

#include <cmath>

#include "core/error.hpp"

namespace bsdfmix {

std::string domain_name(Domain d) { return d == Domain::Fiber ? "fiber" : "hemisphere"; }

Domain parse_domain(const std::string& name, const std::string& where) {
  if (name == "fiber") return Domain::Fiber;
  if (name == "hemisphere") return Domain::Hemisphere;
  throw InputError(where + ": unknown domain '" + name + "' (expected fiber or hemisphere)");
}

std::string map_name(Map m) {
  return m == Map::Disk ? "disk" : (m == Map::Cylinder ? "cylinder" : "theta_phi");
}

Map parse_map(const std::string& name, Domain d, const std::string& where) {
  Map m;
  if (name == "theta_phi") m = Map::ThetaPhi;
  else if (name == "disk") m = Map::Disk;
  else if (name == "cylinder") m = Map::Cylinder;
  else throw InputError(where + ": unknown map '" + name + "' (expected theta_phi, disk or cylinder)");
  if (m != Map::ThetaPhi && m != mix::equal_area_map(d))
    throw InputError(where + ": map '" + name + "' does not fit the " + domain_name(d) + " domain (expected " +
                     map_name(mix::equal_area_map(d)) + " or theta_phi)");
  return m;
}

std::vector<double> uniform_centers(double lo, double hi, std::size_t n) {
  std::vector<double> c(n);
  const double step = (hi - lo) / static_cast<double>(n);
  for (std::size_t i = 0; i < n; ++i) c[i] = lo + (static_cast<double>(i) + 0.5) * step;
  return c;
}

std::size_t nearest_center(const std::vector<double>& axis, double x) {
  std::size_t best = 0;
  for (std::size_t i = 1; i < axis.size(); ++i)
    if (std::abs(axis[i] - x) < std::abs(axis[best] - x)) best = i;
  return best;
}

double axis_step(const std::vector<double>& centers) {
  if (centers.size() < 2) return 2 * kPi;
  return (centers.back() - centers.front()) / static_cast<double>(centers.size() - 1);
}

std::vector<double> integrand_weights(Domain d, const std::vector<double>& theta_i,
                                      const std::vector<double>& phi_i, const float* f) {
  const std::size_t nt = theta_i.size(), np = phi_i.size();
  const double area = axis_step(theta_i) * axis_step(phi_i);
  std::vector<double> w(nt * np);
  for (std::size_t t = 0; t < nt; ++t) {
    double g = jacobian(d, theta_i[t]) * area;
    if (d == Domain::Hemisphere) g *= std::cos(theta_i[t]);
    for (std::size_t p = 0; p < np; ++p) w[t * np + p] = static_cast<double>(f[t * np + p]) * g;
  }
  return w;
}

}  // namespace bsdfmix
