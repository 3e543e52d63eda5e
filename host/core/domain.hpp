// Angular domains, cell grids, Jacobians and integrand weights (docs/formats.md,
// "Angular conventions").
#pragma once

#include <bsdfmix/mixture.hpp>
#include <cstddef>
#include <string>
#include <vector>

namespace bsdfmix {

// From the header (include/bsdfmix/mixture.hpp), the one definition of each: kPi; the
// Domain enum; the theta range of a domain, theta_lo and theta_hi (fiber [-pi/2, pi/2],
// hemisphere [0, pi/2]); jacobian, d(omega) = J(theta) dtheta dphi (cos(theta) for
// fiber, sin(theta) for hemisphere); wrap_phi, phi wrapped into [-pi, pi); bracket, the
// two cells of a uniform axis around a value.
using mix::bracket;
using mix::Bracket;
using mix::Domain;
using mix::Map;
using mix::jacobian;
using mix::kPi;
using mix::theta_hi;
using mix::theta_lo;
using mix::wrap_phi;

// "fiber" / "hemisphere"; parse_domain throws InputError naming `where` on anything else.
std::string domain_name(Domain d);
Domain parse_domain(const std::string& name, const std::string& where);

// "theta_phi" / "disk" / "cylinder" (docs/formats.md, "Maps"); parse_map throws InputError
// naming `where` on anything else, and on a map that does not fit the domain (disk: the
// hemisphere; cylinder: the fiber sphere).
std::string map_name(Map m);
Map parse_map(const std::string& name, Domain d, const std::string& where);

// n cell centers splitting [lo, hi] evenly: lo + (i + 1/2) (hi - lo) / n.
std::vector<double> uniform_centers(double lo, double hi, std::size_t n);

// The index of the center of `axis` nearest x (the first of a tie; 0 for an empty axis).
std::size_t nearest_center(const std::vector<double>& axis, double x);

// Spacing of a uniform axis of centers (2 pi for a single phi_o center).
double axis_step(const std::vector<double>& centers);

// The integrand weight of each cell of one omega_o slice (row-major [theta_i][phi_i]):
// f * cos(theta_i) [hemisphere only] * J(theta_i) * dtheta * dphi. Sum = the slice's
// integral of f over the sphere/hemisphere with L_i = 1.
std::vector<double> integrand_weights(Domain d, const std::vector<double>& theta_i,
                                      const std::vector<double>& phi_i, const float* f);

}  // namespace bsdfmix
