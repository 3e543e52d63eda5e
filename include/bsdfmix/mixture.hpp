// bsdfmix/mixture.hpp: evaluate and importance-sample the Gaussian mixtures of a bsdfmix
// mixture file on the CPU. Self-contained: needs only the C++17 standard library, so a
// renderer can copy this one header. Read the file with any HDF5 reader and fill a
// MixtureSet (see bsdfmix's docs/formats.md, "Mixture file"), or use bsdfmix's own reader.
//
// Conventions. A slice mixture is a density over (theta, phi) in radians, phi periodic
// in [-pi, pi): the density at a point is the sum over components and over the phi
// images phi + 2 pi m of the 2D normal density. Samples whose theta leaves the domain
// ([-pi/2, pi/2] for fibers, [0, pi/2] for the hemisphere) are invalid; pdf() is the
// true density of what sample() returns, so its integral over the domain is
// 1 - P(invalid). pdf_omega = pdf_param / J(theta), J = cos(theta) (fiber) or sin(theta)
// (hemisphere). The stand-in for f is scale * pdf_omega [/ cos(theta_i) for the hemisphere];
// with colour (has_rgb), channel c of it is sum_k rgb[c] of component k times its density,
// over J [and cos(theta_i)] alike (eval_rgb); a slice with colour copies (SliceMixture::colour)
// sums their densities instead, kCopies copies of each component (copy_of).
//
// Loading: bsdfmix/mixture_h5.hpp reads a mixture file into a prepared MixtureSet
// (load_mixture_h5). Filled by hand, a set needs every slice's components, its colour copies
// (SliceMixture::set_copies, 12 amplitudes per component: skipping them changes eval_rgb),
// the file's map, symmetry and interpolation, then MixtureSet::prepare(), which refuses a
// grid that contradicts the slices or the symmetry.
//
// The horizon. On the hemisphere eval_f and eval_rgb are 0 at theta_i = pi/2 (90 deg) and
// beyond, as a renderer expects; pdf_omega is the sampling density: 0 past pi/2, and at
// pi/2 itself its finite limit on the disk map. On the fiber sphere both are 0 outside
// [-pi/2, pi/2]. bsdfmix's device kernels (kernels/sample.cl) return the same.
//
// Random streams. sample_counter(theta_o, phi_o, seed, stream, i) is sample() fed with
// uniforms(seed, stream, i), a counter-based Philox generator: sample i is the same on
// every device and for any batching. `bsdfmix sample --seed S` (S = 1 by default) gives
// samples 0, 1, ... of stream kSampleStream; so does the Python module's sample_counter with
// its defaults (seed 1, stream kSampleStream).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace bsdfmix {
namespace mix {

constexpr double kPi = 3.14159265358979323846;

enum class Domain { Fiber, Hemisphere };

inline double theta_lo(Domain d) { return d == Domain::Fiber ? -kPi / 2 : 0.0; }
inline double theta_hi(Domain) { return kPi / 2; }
inline double jacobian(Domain d, double theta) { return d == Domain::Fiber ? std::cos(theta) : std::sin(theta); }

inline double wrap_phi(double phi) {
  double r = std::fmod(phi + kPi, 2 * kPi);
  if (r < 0) r += 2 * kPi;
  r -= kPi;
  return r >= kPi ? -kPi : r;
}

// The map a mixture lives in (docs/formats.md, "Maps"): the plane (x, y) of its Gaussians.
//  - ThetaPhi: (theta, phi) itself; d(omega) = J(theta) dx dy, so the density per steradian
//    grows like 1 / J at the pole (files written before maps existed);
//  - Disk (hemisphere): Lambert's azimuthal equal-area map,
//    (x, y) = 2 sin(theta / 2) (cos phi, sin phi): the pole at the origin, the horizon the
//    circle of radius sqrt(2);
//  - Cylinder (fiber sphere): Lambert's cylindrical equal-area map, (x, y) = (sin theta, phi):
//    the fiber axis the lines x = +-1.
// Disk and Cylinder are equal-area: d(omega) = dx dy, so a density per unit of (x, y) is a
// density per steradian, bounded wherever the mixture is. In every map y is periodic with
// period 2 pi (a component's density sums its y images); the disk spans |y| <= sqrt(2), so
// there its images only keep sample() and pdf() exact for the rare very broad component.
enum class Map { ThetaPhi, Disk, Cylinder };

// The map a mixture file's `map` attribute names ("theta_phi", "disk", "cylinder"); a file
// without the attribute is in ThetaPhi. Throws std::invalid_argument on any other name.
inline Map map_from_name(const std::string& name) {
  if (name == "theta_phi") return Map::ThetaPhi;
  if (name == "disk") return Map::Disk;
  if (name == "cylinder") return Map::Cylinder;
  throw std::invalid_argument("bsdfmix::mix::map_from_name: unknown map '" + name + "'");
}

// The equal-area map of a domain: Disk for the hemisphere, Cylinder for the fiber sphere.
inline Map equal_area_map(Domain d) { return d == Domain::Hemisphere ? Map::Disk : Map::Cylinder; }

// The point (x, y) of direction (theta, phi) in map m.
inline void to_map(Map m, double theta, double phi, double& x, double& y) {
  if (m == Map::Disk) {
    const double r = 2 * std::sin(0.5 * theta);
    x = r * std::cos(phi);
    y = r * std::sin(phi);
  } else {
    x = m == Map::Cylinder ? std::sin(theta) : theta;
    y = phi;
  }
}

// The direction of map point (x, y), phi wrapped into [-pi, pi); false when the point
// lies outside the map's domain (Disk: beyond the horizon; Cylinder: |x| > 1). ThetaPhi
// returns (x, y) as they are (the caller checks theta's range).
inline bool from_map(Map m, double x, double y, double& theta, double& phi) {
  if (m == Map::Disk) {
    const double r2 = x * x + y * y;
    if (!(r2 <= 2.0)) return false;
    theta = 2 * std::asin(std::min(0.5 * std::sqrt(r2), 1.0));
    phi = r2 > 0 ? wrap_phi(std::atan2(y, x)) : 0.0;
    return true;
  }
  if (m == Map::Cylinder) {
    if (!(std::abs(x) <= 1.0)) return false;
    theta = std::asin(x);
  } else {
    theta = x;
  }
  phi = wrap_phi(y);
  return true;
}

// d(x, y) / d(theta, phi) at theta: the factor from a density per unit of (x, y) to one per
// unit of (theta, phi) (sin theta on the disk, cos theta on the cylinder, 1 for ThetaPhi).
inline double map_jacobian(Map m, double theta) {
  return m == Map::Disk ? std::sin(theta) : (m == Map::Cylinder ? std::cos(theta) : 1.0);
}

// The point (x, y) turned by `angle` about the pole (phi -> phi + angle).
inline void rotate_point(Map m, double angle, double& x, double& y) {
  if (m != Map::Disk) {
    y = wrap_phi(y + angle);
    return;
  }
  const double c = std::cos(angle), s = std::sin(angle), x0 = x;
  x = c * x0 - s * y;
  y = s * x0 + c * y;
}

// The two cells of a uniform axis around x and the weight toward the second, f in [0, 1]:
// x = (1 - f) c[i0] + f c[i1] for the cell centers c[i] = first + i step, i = 0 .. n - 1.
// A clamped axis (periodic false) holds its end cell beyond either end (i0 = i1, f = 0);
// a periodic one repeats every n cells (i1 = (i0 + 1) % n). One cell: (0, 0, 0).
struct Bracket {
  std::size_t i0 = 0, i1 = 0;
  double f = 0;
};

inline Bracket bracket(double first, double step, std::size_t n, double x, bool periodic) {
  Bracket b;
  if (n <= 1) return b;
  double u = (x - first) / step;
  if (periodic) {
    u = std::fmod(u, double(n));
    if (u < 0) u += double(n);
    b.i0 = std::min(static_cast<std::size_t>(u), n - 1);
    b.i1 = (b.i0 + 1) % n;
    b.f = u - double(b.i0);
  } else if (u <= 0) {
    b.i0 = b.i1 = 0;
  } else if (u >= double(n - 1)) {
    b.i0 = b.i1 = n - 1;
  } else {
    b.i0 = static_cast<std::size_t>(u);
    b.i1 = b.i0 + 1;
    b.f = u - double(b.i0);
  }
  return b;
}

// The same on an axis given by its (uniformly spaced) cell centers.
inline Bracket bracket(const std::vector<double>& axis, double x, bool periodic) {
  const std::size_t n = axis.size();
  if (n <= 1) return {};
  return bracket(axis.front(), (axis.back() - axis.front()) / double(n - 1), n, x, periodic);
}

// One 2D Gaussian with precomputed inverse, normalization and Cholesky factor.
struct Gaussian {
  double weight = 0, mu_t = 0, mu_p = 0;
  double s_tt = 0, s_tp = 0, s_pp = 0;
  double rgb[3] = {0, 0, 0};  // with SliceMixture::has_rgb: the component's amplitude per channel (rgb_scale)
  // derived by prepare()
  double i_tt = 0, i_tp = 0, i_pp = 0;  // inverse covariance
  double norm = 0;                      // 1 / (2 pi sqrt(det))
  double l_tt = 0, l_pt = 0, l_pp = 0;  // Cholesky: [l_tt 0; l_pt l_pp]
  int images = 1;                       // phi images on each side that matter
  double cut = 0;                       // 9 sigma_phi: images farther than this add < 1e-17

  // Throws std::invalid_argument when the covariance is not positive definite.
  void prepare() {
    const double det = s_tt * s_pp - s_tp * s_tp;
    if (!(s_tt > 0) || !(s_pp > 0) || !(det > 0) || !std::isfinite(det))
      throw std::invalid_argument("bsdfmix::mix::Gaussian: covariance is not positive definite");
    i_tt = s_pp / det;
    i_tp = -s_tp / det;
    i_pp = s_tt / det;
    norm = 1.0 / (2 * kPi * std::sqrt(det));
    l_tt = std::sqrt(s_tt);
    l_pt = s_tp / l_tt;
    l_pp = std::sqrt(std::max(s_pp - l_pt * l_pt, 0.0));
    // Images m with |m| <= images cover every phi in [-pi, pi) to within 9 sigma.
    // (Means outside [-pi, pi) are allowed: the bound includes |mu_p|.)
    cut = 9.0 * std::sqrt(s_pp);
    images = static_cast<int>(std::ceil((cut + kPi + std::abs(mu_p)) / (2 * kPi)));
  }

  // The larger standard deviation (radians): the square root of the covariance's larger
  // eigenvalue.
  double sigma_max() const {
    return std::sqrt(0.5 * (s_tt + s_pp) + std::sqrt(0.25 * (s_tt - s_pp) * (s_tt - s_pp) + s_tp * s_tp));
  }

  // Density at (theta, phi), phi in [-pi, pi), summed over the phi images.
  double density(double theta, double phi) const {
    const double dt = theta - mu_t;
    double sum = 0;
    for (int m = -images; m <= images; ++m) {
      const double dp = phi + 2 * kPi * m - mu_p;
      if (std::abs(dp) > cut) continue;
      const double q = i_tt * dt * dt + 2 * i_tp * dt * dp + i_pp * dp * dp;
      if (q < 1500) sum += std::exp(-0.5 * q);  // beyond, exp underflows to 0 (slowly)
    }
    return norm * sum;
  }
};

// Colour copies (bsdfmix's docs/formats.md, "Colour copies"): a slice whose colour varies
// across a component carries four amplitudes per component and channel, one on each of
// four copies of it. Copy m is the component moved by kCopyOffset along one axis of its
// Cholesky factor L (m = 0, 1: -, + L e_theta; m = 2, 3: -, + L e_phi), with covariance
// (1 - kCopyOffset^2 / 2) times the component's: four copies of equal amplitude have the
// component's mean and covariance. Only the colour uses them; sampling and the luminance
// stand-in keep the components.
constexpr int kCopies = 4;
constexpr double kCopyOffset = 0.5;

// Copy m (0 .. kCopies - 1) of g, with amplitudes rgb (not prepared).
inline Gaussian copy_of(const Gaussian& g, int m, const double rgb[3]) {
  const double l_tt = std::sqrt(g.s_tt), l_pt = g.s_tp / l_tt;
  const double l_pp = std::sqrt(std::max(g.s_pp - l_pt * l_pt, 0.0));
  const double sign = (m % 2) ? 1.0 : -1.0, shrink = 1 - 0.5 * kCopyOffset * kCopyOffset;
  Gaussian c;
  c.mu_t = g.mu_t + (m < 2 ? sign * kCopyOffset * l_tt : 0.0);
  c.mu_p = g.mu_p + (m < 2 ? sign * kCopyOffset * l_pt : sign * kCopyOffset * l_pp);
  c.s_tt = shrink * g.s_tt;
  c.s_tp = shrink * g.s_tp;
  c.s_pp = shrink * g.s_pp;
  for (int q = 0; q < 3; ++q) c.rgb[q] = rgb[q];
  return c;
}

// g turned by `angle` about the pole of map m (mean and covariance; not prepared):
// a shift of mu_p on ThetaPhi and Cylinder, a rotation of the plane on Disk.
inline Gaussian rotated(Map m, const Gaussian& g, double angle) {
  Gaussian r = g;
  if (m != Map::Disk) {
    r.mu_p = wrap_phi(g.mu_p + angle);
    return r;
  }
  rotate_point(m, angle, r.mu_t, r.mu_p);
  const double c = std::cos(angle), s = std::sin(angle);
  // R S R^T with R = [c -s; s c]
  r.s_tt = c * c * g.s_tt - 2 * c * s * g.s_tp + s * s * g.s_pp;
  r.s_tp = c * s * (g.s_tt - g.s_pp) + (c * c - s * s) * g.s_tp;
  r.s_pp = s * s * g.s_tt + 2 * c * s * g.s_tp + c * c * g.s_pp;
  return r;
}

struct Sample {
  double theta = 0, phi = 0;  // radians; phi wrapped into [-pi, pi)
  double pdf_omega = 0;       // density per steradian of what was sampled
  bool valid = false;         // false when theta left the domain: zero contribution
};

// The Lambertian base on the disk: the cosine-weighted density cos(theta) / pi per
// steradian, at map point (x, y): (1 - (x^2 + y^2) / 2) / pi inside the disk, 0 outside.
inline double lambert_base(double x, double y) {
  const double c = 1.0 - 0.5 * (x * x + y * y);
  return c > 0 ? c / kPi : 0.0;
}

// A draw of the Lambertian base from two uniforms (Malley: uniform on the unit disk, lifted),
// as a disk point (x, y).
inline void lambert_draw(double u2, double u3, double& x, double& y) {
  const double sin_t = std::sqrt(u2), theta = std::asin(std::min(sin_t, 1.0)), phi = 2 * kPi * u3 - kPi;
  to_map(Map::Disk, theta, phi, x, y);
}

// Unit normal pair from two uniforms (Box-Muller), u1 in [0, 1).
inline void normal_pair(double u1, double u2, double& z0, double& z1) {
  const double r = std::sqrt(-2.0 * std::log(1.0 - u1));
  z0 = r * std::cos(2 * kPi * u2);
  z1 = r * std::sin(2 * kPi * u2);
}

// The mixture of one omega_o slice.
struct SliceMixture {
  double theta_o = 0, phi_o = 0;
  double scale = 0;  // the luminance stand-in's amplitude: scale * pdf_param is the integrand
  // The uniform share a sampler mixes in with this mixture (the file's `defensive`; 0.1 in
  // files without it): the smallest share whose largest importance weight on the table is
  // at most 3 times the integral, or no larger than with 0.1 (docs/sampling.md, "The earned
  // share").
  double defensive = 0.1;
  bool has_rgb = false;  // the components' rgb amplitudes are set (else the colour is grey: eval_f)
  Map map = Map::ThetaPhi;  // the plane of the components (MixtureSet::prepare sets the file's)
  // The Lambertian base (Disk only, docs/formats.md "The base"): its weight beside the
  // components' (normalized with them by prepare) and its colour amplitudes (with has_rgb).
  double base = 0;
  double base_rgb[3] = {0, 0, 0};
  std::vector<Gaussian> components;
  // With colour copies: the Gaussians that carry the colour (copy_of each component's
  // kCopies copies, component-major, each with its own rgb); empty: the components' rgb.
  std::vector<Gaussian> colour;
  std::vector<double> cdf;  // cumulative weights, built by prepare()

  // Gives the slice colour copies: amp holds kCopies x 3 amplitudes per component
  // ([component][copy][channel]); call before prepare().
  void set_copies(const std::vector<double>& amp) {
    if (amp.size() != components.size() * kCopies * 3)
      throw std::invalid_argument("bsdfmix::mix::SliceMixture: colour copies need 12 amplitudes per component");
    colour.clear();
    for (std::size_t k = 0; k < components.size(); ++k)
      for (int m = 0; m < kCopies; ++m) colour.push_back(copy_of(components[k], m, &amp[(k * kCopies + m) * 3]));
  }

  void prepare() {
    if (base < 0 || (base > 0 && map != Map::Disk))
      throw std::invalid_argument("bsdfmix::mix::SliceMixture: a base needs the disk map and a weight >= 0");
    for (auto& g : colour) g.prepare();
    cdf.clear();
    double acc = base;
    for (auto& g : components) {
      g.prepare();
      acc += g.weight;
      cdf.push_back(acc);
    }
    if (!(acc > 0)) throw std::invalid_argument("bsdfmix::mix::SliceMixture: weights sum to zero");
    for (auto& c : cdf) c /= acc;
    for (auto& g : components) g.weight /= acc;
    base /= acc;
  }

  // The density per unit of the map's (x, y) (per steradian on an equal-area map).
  double pdf_map(double x, double y) const {
    double p = base > 0 ? base * lambert_base(x, y) : 0.0;
    for (const auto& g : components) p += g.weight * g.density(x, y);
    return p;
  }

  // The density per unit of (theta, phi) at a direction, whatever the map: pdf_map times
  // map_jacobian (on ThetaPhi, pdf_map itself).
  double pdf_param(double theta, double phi) const {
    if (map == Map::ThetaPhi) return pdf_map(theta, phi);
    double x, y;
    to_map(map, theta, phi, x, y);
    return pdf_map(x, y) * map_jacobian(map, theta);
  }

  // The stand-in over (theta, phi), i.e. the integrand f [cos(theta)] J: scale * pdf_param.
  double eval_param(double theta, double phi) const { return scale * pdf_param(theta, phi); }

  // The same per channel: sum_k rgb[c] N_k with colour, else eval_param in every channel.
  void eval_rgb_param(double theta, double phi, double out[3]) const {
    if (map == Map::ThetaPhi) return eval_rgb_map(theta, phi, out);
    double x, y;
    to_map(map, theta, phi, x, y);
    eval_rgb_map(x, y, out);
    const double j = map_jacobian(map, theta);
    for (int c = 0; c < 3; ++c) out[c] *= j;
  }

  // eval_rgb_param per unit of the map's (x, y).
  void eval_rgb_map(double x, double y, double out[3]) const {
    if (!has_rgb) {
      out[0] = out[1] = out[2] = scale * pdf_map(x, y);
      return;
    }
    const double b = base > 0 ? lambert_base(x, y) : 0.0;
    for (int c = 0; c < 3; ++c) out[c] = base_rgb[c] * b;
    for (const auto& g : colour.empty() ? components : colour) {
      const double d = g.density(x, y);
      for (int c = 0; c < 3; ++c) out[c] += g.rgb[c] * d;
    }
  }

  // A point of the map's plane from three uniforms: u1 picks the base (u1 < base) or a
  // component, (u2, u3) the point (y wrapped).
  void draw_map(double u1, double u2, double u3, double& x, double& y) const {
    if (u1 < base || components.empty()) return lambert_draw(u2, u3, x, y);
    const Gaussian& g = components[pick(u1)];
    double z0, z1;
    normal_pair(u2, u3, z0, z1);
    x = g.mu_t + g.l_tt * z0;
    y = wrap_phi(g.mu_p + g.l_pt * z0 + g.l_pp * z1);
  }

  // Component index for u in [0, 1): binary search of the CDF.
  std::size_t pick(double u) const {
    const auto it = std::upper_bound(cdf.begin(), cdf.end(), u);
    return std::min(static_cast<std::size_t>(it - cdf.begin()), components.size() - 1);
  }

  // Density per steradian of what sample() returns, at (theta, phi) of the domain.
  double pdf_omega(Domain d, double theta, double phi) const {
    if (theta < theta_lo(d) || theta > theta_hi(d)) return 0;
    if (map != Map::ThetaPhi) {
      double x, y;
      to_map(map, theta, phi, x, y);
      return pdf_map(x, y);
    }
    const double j = jacobian(d, theta);
    return j > 0 ? pdf_param(theta, wrap_phi(phi)) / j : 0.0;
  }

  // A sample of this mixture alone: u1 picks the component, (u2, u3) the point. Invalid
  // when it leaves the domain.
  Sample sample(Domain d, double u1, double u2, double u3) const {
    Sample out;
    if (map != Map::ThetaPhi) {
      double x, y;
      draw_map(u1, u2, u3, x, y);
      out.valid = from_map(map, x, y, out.theta, out.phi);
      out.pdf_omega = out.valid ? pdf_map(x, y) : 0.0;
      if (!(out.pdf_omega > 0)) out.valid = false;
      return out;
    }
    const Gaussian& g = components[pick(u1)];
    double z0, z1;
    normal_pair(u2, u3, z0, z1);
    out.theta = g.mu_t + g.l_tt * z0;
    out.phi = wrap_phi(g.mu_p + g.l_pt * z0 + g.l_pp * z1);
    out.valid = out.theta >= theta_lo(d) && out.theta <= theta_hi(d);
    out.pdf_omega = out.valid ? pdf_omega(d, out.theta, out.phi) : 0.0;
    if (!(out.pdf_omega > 0)) out.valid = false;
    return out;
  }
};

// A slice mixture from the parameter arrays of its k components, row-major as a mixture
// file stores them: weights [k], means [k][2] (mu_theta, mu_phi), covariances [k][3]
// (s_tt, s_tp, s_pp) and, when `rgb` is not null, the channel amplitudes [k][3] (has_rgb);
// float or double. Not prepared: give it its colour copies (set_copies) if it has some,
// then prepare().
template <typename T, typename A = double>
SliceMixture slice_from_arrays(std::size_t k, const T* weight, const T* mean, const T* cov, const A* rgb = nullptr) {
  SliceMixture m;
  m.has_rgb = rgb != nullptr;
  for (std::size_t j = 0; j < k; ++j) {
    Gaussian g;
    g.weight = weight[j];
    g.mu_t = mean[2 * j];
    g.mu_p = mean[2 * j + 1];
    g.s_tt = cov[3 * j];
    g.s_tp = cov[3 * j + 1];
    g.s_pp = cov[3 * j + 2];
    for (int c = 0; rgb && c < 3; ++c) g.rgb[c] = rgb[3 * j + std::size_t(c)];
    m.components.push_back(g);
  }
  return m;
}

// The same from vectors (weights K, means 2K, covariances 3K), prepared.
inline SliceMixture make_slice_mixture(const std::vector<double>& weight, const std::vector<double>& mean,
                                       const std::vector<double>& cov) {
  if (mean.size() != 2 * weight.size() || cov.size() != 3 * weight.size())
    throw std::invalid_argument("bsdfmix::mix::make_slice_mixture: weights K, means 2K and covariances 3K disagree");
  SliceMixture m = slice_from_arrays(weight.size(), weight.data(), mean.data(), cov.data());
  m.prepare();
  return m;
}

// The cosine dome on the disk, (1 - |x|^2 / 2) / pi, as product() takes a Lambertian base:
// a fixed fit of 7 Gaussians, one at the pole and 6 on a ring (the least L1 over the
// plane: 7.8%, 2.5% of the mass past the horizon; one isotropic Gaussian of sigma 0.75
// is 40% and 17%).
struct BaseFit {
  static constexpr double kPoleWeight = 0.4501, kPoleSigma = 0.4637;
  static constexpr double kRingRadius = 0.8276, kRingRadial = 0.2764, kRingTangential = 0.3994;
  static constexpr int kRing = 6;
};

// A base of `weight` as BaseFit's Gaussians on the disk (prepared; weights summing to it).
inline std::vector<Gaussian> base_gaussians(double weight) {
  std::vector<Gaussian> out;
  Gaussian pole;
  pole.weight = weight * BaseFit::kPoleWeight;
  pole.s_tt = pole.s_pp = BaseFit::kPoleSigma * BaseFit::kPoleSigma;
  pole.prepare();
  out.push_back(pole);
  const double rr = BaseFit::kRingRadial * BaseFit::kRingRadial, tt = BaseFit::kRingTangential * BaseFit::kRingTangential;
  for (int k = 0; k < BaseFit::kRing; ++k) {
    const double a = 2 * kPi * k / BaseFit::kRing, c = std::cos(a), s = std::sin(a);
    Gaussian g;
    g.weight = weight * (1 - BaseFit::kPoleWeight) / BaseFit::kRing;
    g.mu_t = BaseFit::kRingRadius * c;
    g.mu_p = BaseFit::kRingRadius * s;
    g.s_tt = c * c * rr + s * s * tt;  // R diag(radial^2, tangential^2) R^T
    g.s_pp = s * s * rr + c * c * tt;
    g.s_tp = c * s * (rr - tt);
    g.prepare();
    out.push_back(g);
  }
  return out;
}

// What a slice brings to a product: its Gaussians and, where it has a Lambertian base,
// BaseFit's Gaussians for it. The product stays a mixture of Gaussians, and its pdf is
// exactly what its sample() draws.
inline std::vector<Gaussian> product_parts(const SliceMixture& m) {
  std::vector<Gaussian> parts = m.components;
  if (m.base > 0)
    for (const Gaussian& g : base_gaussians(m.base)) parts.push_back(g);
  return parts;
}

// How product() prunes: the heaviest component pairs are kept until they hold `keep` of
// the product's mass, and at most `max_components` of them.
struct ProductOptions {
  double keep = 0.999;
  std::size_t max_components = 128;
};

// The product of two periodic mixtures over one map's (x, y): `a` shifted by `rotate_a` in
// phi, times `b`, as a mixture (prepared: weights normalized). For components i of a
// and j of b and a phi image offset d, the product of the two normal densities is
//   N(x; m_i, S_i) N(x; m_j, S_j) = c N(x; m, S),  m_i = mu_i + (0, rotate_a + 2 pi d),
//   S = (S_i^-1 + S_j^-1)^-1,  m = S (S_i^-1 m_i + S_j^-1 m_j),  c = N(m_i; m_j, S_i + S_j),
// and summing over the images makes the product of the two periodic densities exactly
// the mixture of the periodic components N(m, S) with weights w_i w_j c over (i, j, d).
// Pairs are pruned heaviest first (ProductOptions); the result is a true density of what
// its sample() returns, whatever was pruned. `mass`, when given, receives the integral of
// the product over theta in R and one phi period before pruning, and `kept` the share of
// it the result keeps. Throws std::invalid_argument when the product is zero.
inline SliceMixture product(const SliceMixture& a, double rotate_a, const SliceMixture& b,
                            const ProductOptions& o = {}, double* mass = nullptr, double* kept = nullptr) {
  if (a.map != b.map) throw std::invalid_argument("bsdfmix::mix::product: the two mixtures live in different maps");
  if (a.map == Map::Disk && rotate_a != 0) {  // a turn of the disk is not a shift of y
    SliceMixture turned = a;
    for (Gaussian& g : turned.components) g = rotated(a.map, g, rotate_a);
    turned.colour.clear();
    turned.prepare();
    return product(turned, 0.0, b, o, mass, kept);
  }
  struct Term {
    double w;
    Gaussian g;
  };
  std::vector<Term> terms;
  double total = 0;
  const std::vector<Gaussian> parts[2] = {product_parts(a), product_parts(b)};
  for (const Gaussian& x : parts[0])
    for (const Gaussian& y : parts[1]) {
      const double st = x.s_tt + y.s_tt, sp = x.s_pp + y.s_pp, sx = x.s_tp + y.s_tp;
      const double det = st * sp - sx * sx;
      if (!(det > 0)) continue;
      const double dt = x.mu_t - y.mu_t, dp0 = wrap_phi(x.mu_p + rotate_a - y.mu_p);
      const double sig = std::sqrt(sp);
      const int reach = static_cast<int>(std::ceil(9.0 * sig / (2 * kPi))) + 1;
      // the product's covariance: the inverse of the summed precisions
      const double pdet = (x.i_tt + y.i_tt) * (x.i_pp + y.i_pp) - (x.i_tp + y.i_tp) * (x.i_tp + y.i_tp);
      if (!(pdet > 0)) continue;
      Gaussian g;
      g.s_tt = (x.i_pp + y.i_pp) / pdet;
      g.s_tp = -(x.i_tp + y.i_tp) / pdet;
      g.s_pp = (x.i_tt + y.i_tt) / pdet;
      for (int d = -reach; d <= reach; ++d) {
        const double dp = dp0 + 2 * kPi * d;
        if (std::abs(dp) > 9.0 * sig) continue;
        const double q = (sp * dt * dt - 2 * sx * dt * dp + st * dp * dp) / det;
        const double c = std::exp(-0.5 * q) / (2 * kPi * std::sqrt(det));
        const double w = x.weight * y.weight * c;
        if (!(w > 0)) continue;
        // m_i = (x.mu_t, y.mu_p + dp): the shifted image of x's mean nearest b's component
        const double at = x.mu_t, ap = y.mu_p + dp;
        const double ht = x.i_tt * at + x.i_tp * ap + y.i_tt * y.mu_t + y.i_tp * y.mu_p;
        const double hp = x.i_tp * at + x.i_pp * ap + y.i_tp * y.mu_t + y.i_pp * y.mu_p;
        Gaussian r = g;
        r.mu_t = r.s_tt * ht + r.s_tp * hp;
        r.mu_p = wrap_phi(r.s_tp * ht + r.s_pp * hp);
        r.weight = w;
        terms.push_back({w, r});
        total += w;
      }
    }
  if (!(total > 0)) throw std::invalid_argument("bsdfmix::mix::product: the two mixtures do not overlap");
  std::sort(terms.begin(), terms.end(), [](const Term& p, const Term& q) { return p.w > q.w; });
  SliceMixture out;
  double acc = 0;
  for (const Term& t : terms) {
    if (out.components.size() >= std::max<std::size_t>(o.max_components, 1)) break;
    if (!out.components.empty() && acc >= o.keep * total) break;
    out.components.push_back(t.g);
    acc += t.w;
  }
  out.scale = total;
  out.map = a.map;
  if (mass) *mass = total;
  if (kept) *kept = acc / total;
  out.prepare();
  return out;
}


// How a MixtureSet serves an omega_o between two fitted slices (docs/formats.md,
// "Interpolation between slices"):
//  - Blend mixes the two slices' mixtures with the linear weights of thesis eq. 3.7: a
//    lobe that moves with omega_o becomes two half-lobes at the two slices' places;
//  - Displace moves the lobes instead (displacement interpolation, Bonneel et al. 2011):
//    the components that can be one lobe in both slices (compact and alike: same_lobe)
//    are matched by a transport plan over the squared 2-Wasserstein distance, and each
//    matched pair (i, j) of mass m becomes one component of weight m whose mean and
//    covariance go linearly from i's to j's; the unmatched mass is blended. A lobe that
//    moves between the slices is one lobe in between.
// Either way the result is one mixture, and pdf() is the exact density of what sample()
// draws.
enum class Interpolation { Blend, Displace };

// One matched pair of a transport plan: component i of the lower slice, j of the upper,
// and the mass carried from i to j.
struct Flow {
  int i = 0, j = 0;
  double mass = 0;
};

// A partial transport plan between two slices: the matched pairs, and the mass of each
// component that no pair carries (left_a[i] of the lower slice's component i, left_b[j]
// of the upper's).
struct Transport {
  std::vector<Flow> flows;
  std::vector<double> left_a, left_b;
};

// The squared 2-Wasserstein distance of two 2D normals, phi measured the short way:
// |mu_x - mu_y|^2 + tr Sx + tr Sy - 2 tr (Sx^1/2 Sy Sx^1/2)^1/2; for 2 x 2 matrices
// tr M^1/2 = sqrt(tr M + 2 sqrt(det M)), and Sx^1/2 Sy Sx^1/2 has the trace and
// determinant of Sx Sy.
inline double w2_squared(const Gaussian& x, const Gaussian& y) {
  const double dt = y.mu_t - x.mu_t, dp = wrap_phi(y.mu_p - x.mu_p);
  const double tr_xy = x.s_tt * y.s_tt + 2 * x.s_tp * y.s_tp + x.s_pp * y.s_pp;
  const double det = std::max(x.s_tt * x.s_pp - x.s_tp * x.s_tp, 0.0) * std::max(y.s_tt * y.s_pp - y.s_tp * y.s_tp, 0.0);
  const double cross = std::sqrt(std::max(tr_xy + 2 * std::sqrt(det), 0.0));
  return dt * dt + dp * dp + std::max(x.s_tt + x.s_pp + y.s_tt + y.s_pp - 2 * cross, 0.0);
}

// Whether two components can be one lobe that moved: both compact (no standard deviation
// above kMovingSigma: broader components, bands across phi above all, are cut differently
// by each slice's fit and are blended instead), their means at most `reach` apart, and
// alike in shape (the covariance part of w2_squared at most half the smaller trace).
constexpr double kMovingSigma = 0.35;

inline bool same_lobe(const Gaussian& x, const Gaussian& y, double reach) {
  if (x.sigma_max() > kMovingSigma || y.sigma_max() > kMovingSigma) return false;
  const double dt = y.mu_t - x.mu_t, dp = wrap_phi(y.mu_p - x.mu_p);
  if (dt * dt + dp * dp > reach * reach) return false;
  const double shape = w2_squared(x, y) - dt * dt - dp * dp;
  return shape <= 0.5 * std::min(x.s_tt + x.s_pp, y.s_tt + y.s_pp);
}

// A partial transport plan between the normalized weights of a and b (prepared
// mixtures): over the pairs that can be one lobe (same_lobe), the cheapest by w2_squared
// first, each carrying as much mass as both ends have left (a greedy plan). Mass left
// unmatched stays where it is: displaced() blends it.
inline Transport transport_plan(const SliceMixture& a, const SliceMixture& b) {
  const std::size_t na = a.components.size(), nb = b.components.size();
  struct Pair {
    double cost;
    int i, j;
  };
  std::vector<Pair> pairs;
  pairs.reserve(na * nb);
  // A reflected lobe moves by about the change of omega_o: twice that, at least 0.05 rad.
  const double reach = std::max(2 * (std::abs(b.theta_o - a.theta_o) + std::abs(wrap_phi(b.phi_o - a.phi_o))), 0.05);
  for (std::size_t i = 0; i < na; ++i)
    for (std::size_t j = 0; j < nb; ++j)
      if (same_lobe(a.components[i], b.components[j], reach))
        pairs.push_back({w2_squared(a.components[i], b.components[j]), int(i), int(j)});
  std::sort(pairs.begin(), pairs.end(), [](const Pair& x, const Pair& y) {
    return x.cost < y.cost || (x.cost == y.cost && (x.i < y.i || (x.i == y.i && x.j < y.j)));
  });
  Transport plan;
  plan.left_a.resize(na);
  plan.left_b.resize(nb);
  for (std::size_t i = 0; i < na; ++i) plan.left_a[i] = a.components[i].weight;
  for (std::size_t j = 0; j < nb; ++j) plan.left_b[j] = b.components[j].weight;
  for (const Pair& p : pairs) {
    double& la = plan.left_a[std::size_t(p.i)];
    double& lb = plan.left_b[std::size_t(p.j)];
    const double m = std::min(la, lb);
    if (!(m > 0)) continue;
    plan.flows.push_back({p.i, p.j, m});
    la -= m;
    lb -= m;
  }
  return plan;
}

// The mixture a fraction t of the way from a to b along `plan` (transport_plan(a, b)),
// in the slices' own phi frame: components as described at Interpolation, scale linear
// in t, colour amplitudes shared by each pair in proportion to the mass it carries.
inline SliceMixture displaced(const SliceMixture& a, const SliceMixture& b, const Transport& plan, double t) {
  auto between = [t](const Gaussian& x, const Gaussian& y, double share_x, double share_y) {
    Gaussian g;
    g.mu_t = (1 - t) * x.mu_t + t * y.mu_t;
    g.mu_p = wrap_phi(x.mu_p + t * wrap_phi(y.mu_p - x.mu_p));
    g.s_tt = (1 - t) * x.s_tt + t * y.s_tt;
    g.s_tp = (1 - t) * x.s_tp + t * y.s_tp;
    g.s_pp = (1 - t) * x.s_pp + t * y.s_pp;
    for (int c = 0; c < 3; ++c) g.rgb[c] = (1 - t) * share_x * x.rgb[c] + t * share_y * y.rgb[c];
    return g;
  };
  SliceMixture out;
  out.theta_o = (1 - t) * a.theta_o + t * b.theta_o;
  out.phi_o = a.phi_o + t * wrap_phi(b.phi_o - a.phi_o);
  out.scale = (1 - t) * a.scale + t * b.scale;
  out.defensive = (1 - t) * a.defensive + t * b.defensive;
  out.map = a.map;
  out.base = (1 - t) * a.base + t * b.base;
  for (int c = 0; c < 3; ++c) out.base_rgb[c] = (1 - t) * a.base_rgb[c] + t * b.base_rgb[c];
  out.has_rgb = a.has_rgb && b.has_rgb;
  const bool copies = out.has_rgb && (!a.colour.empty() || !b.colour.empty());
  // A component's kCopies colour Gaussians: its copies, or (a slice without copies) copy_of
  // the component with a quarter of its amplitudes each.
  auto copy = [](const SliceMixture& s, int k, int m) {
    if (!s.colour.empty()) return s.colour[std::size_t(k * kCopies + m)];
    const Gaussian& g = s.components[std::size_t(k)];
    const double rgb[3] = {g.rgb[0] / kCopies, g.rgb[1] / kCopies, g.rgb[2] / kCopies};
    return copy_of(g, m, rgb);
  };
  // Unmatched mass: a's share fades out as (1 - t), b's fades in as t, in place.
  auto stay = [&](const SliceMixture& s, std::size_t k, double left, double share) {
    const Gaussian& x = s.components[k];
    if (!(left > 1e-12 * x.weight) || !(share > 0)) return;
    Gaussian g = x;
    const double r = x.weight > 0 ? left / x.weight : 0;
    g.weight = share * left;
    for (double& c : g.rgb) c *= share * r;
    out.components.push_back(g);
    if (copies)
      for (int m = 0; m < kCopies; ++m) {
        Gaussian c = copy(s, int(k), m);
        for (double& v : c.rgb) v *= share * r;
        out.colour.push_back(c);
      }
  };
  for (std::size_t i = 0; i < plan.left_a.size(); ++i) stay(a, i, plan.left_a[i], 1 - t);
  for (std::size_t j = 0; j < plan.left_b.size(); ++j) stay(b, j, plan.left_b[j], t);
  for (const Flow& f : plan.flows) {
    const Gaussian& x = a.components[std::size_t(f.i)];
    const Gaussian& y = b.components[std::size_t(f.j)];
    const double sx = x.weight > 0 ? f.mass / x.weight : 0, sy = y.weight > 0 ? f.mass / y.weight : 0;
    Gaussian g = between(x, y, sx, sy);
    g.weight = f.mass;
    out.components.push_back(g);
    if (copies)
      for (int m = 0; m < kCopies; ++m) out.colour.push_back(between(copy(a, f.i, m), copy(b, f.j, m), sx, sy));
  }
  out.prepare();
  return out;
}

// Counter-based random numbers: Philox4x32-10 (Salmon et al. 2011, the Random123
// generator), so that sample i of a stream is the same on every device and for any
// batching. bsdfmix's kernels (kernels/sample.cl) use the same function and the same
// counter layout: sample i of `stream` under `seed` uses
//   counter = {i low 32 bits, i high 32 bits, stream, 0}, key = {seed low, seed high}.
struct PhiloxBlock {
  std::uint32_t v[4];
};

inline PhiloxBlock philox4x32_10(const std::uint32_t ctr[4], const std::uint32_t key[2]) {
  std::uint32_t c0 = ctr[0], c1 = ctr[1], c2 = ctr[2], c3 = ctr[3];
  std::uint32_t k0 = key[0], k1 = key[1];
  for (int r = 0; r < 10; ++r) {
    if (r > 0) {
      k0 += 0x9E3779B9u;
      k1 += 0xBB67AE85u;
    }
    const std::uint64_t p0 = std::uint64_t(0xD2511F53u) * c0;
    const std::uint64_t p1 = std::uint64_t(0xCD9E8D57u) * c2;
    const std::uint32_t hi0 = std::uint32_t(p0 >> 32), lo0 = std::uint32_t(p0);
    const std::uint32_t hi1 = std::uint32_t(p1 >> 32), lo1 = std::uint32_t(p1);
    c0 = hi1 ^ c1 ^ k0;
    c1 = lo1;
    c2 = hi0 ^ c3 ^ k1;
    c3 = lo0;
  }
  return {{c0, c1, c2, c3}};
}

// A 32-bit word to a uniform in [0, 1) with 24 bits: exact in float and double alike.
inline double to_uniform(std::uint32_t x) { return double(x >> 8) * (1.0 / 16777216.0); }

// The stream of `bsdfmix sample` and of the Python module's sample_counter ("samp").
constexpr std::uint32_t kSampleStream = 0x73616d70u;

// The four uniforms of sample `index` of `stream` under `seed` (layout above).
inline void uniforms(std::uint64_t seed, std::uint32_t stream, std::uint64_t index, double u[4]) {
  const std::uint32_t ctr[4] = {std::uint32_t(index), std::uint32_t(index >> 32), stream, 0u};
  const std::uint32_t key[2] = {std::uint32_t(seed), std::uint32_t(seed >> 32)};
  const PhiloxBlock r = philox4x32_10(ctr, key);
  for (int i = 0; i < 4; ++i) u[i] = to_uniform(r.v[i]);
}

// All fitted slices of a mixture file, on the table's omega_o grid.
class MixtureSet {
 public:
  Domain domain = Domain::Fiber;
  Map map = Map::ThetaPhi;     // the plane of every slice's components (the file's `map`)
  bool azimuthal = true;       // f depends on phi_i - phi_o only
  std::vector<double> grid_theta_o, grid_phi_o;  // the table's omega_o axes (cell centers)
  std::vector<SliceMixture> slices;              // fitted slices
  std::vector<int> slice_of;  // [grid_theta_o x grid_phi_o] -> index into slices, -1 if not fitted
  Interpolation interpolation = Interpolation::Blend;  // between fitted slices along theta_o

  // Prepares components, the grid lookup and (Displace) the transport plans between
  // neighbouring fitted slices. Call once after filling the fields. Throws
  // std::invalid_argument when the fields contradict each other (check_grid).
  void prepare() {
    check_grid();
    for (auto& s : slices) {
      s.map = map;
      s.prepare();
    }
    const std::size_t np = azimuthal ? 1 : grid_phi_o.size();
    slice_of.assign(grid_theta_o.size() * np, -1);
    for (std::size_t s = 0; s < slices.size(); ++s) {
      const std::size_t t = nearest(grid_theta_o, slices[s].theta_o);
      const std::size_t p = azimuthal ? 0 : nearest(grid_phi_o, slices[s].phi_o);
      slice_of[t * np + p] = static_cast<int>(s);
    }
    plan_up_.assign(slices.size(), {});
    if (interpolation != Interpolation::Displace) return;
    for (std::size_t p = 0; p < np; ++p) {
      int below = -1;
      for (std::size_t t = 0; t < grid_theta_o.size(); ++t) {
        const int s = slice_of[t * np + p];
        if (s < 0) continue;
        if (below >= 0) plan_up_[std::size_t(below)] = transport_plan(slices[std::size_t(below)], slices[std::size_t(s)]);
        below = s;
      }
    }
  }

  // Throws std::invalid_argument, naming the field, when the grid and the slices disagree:
  // an empty, unsorted or non-uniform axis; azimuthal with more than one grid_phi_o column;
  // not azimuthal with a single column (one column at phi_o = 0 is what azimuthal symmetry
  // stores: set azimuthal); a slice off the grid, or two slices on one grid cell.
  void check_grid() const {
    auto bad = [](const std::string& what) {
      throw std::invalid_argument("bsdfmix::mix::MixtureSet: " + what);
    };
    for (const auto* axis : {&grid_theta_o, &grid_phi_o}) {
      const char* name = axis == &grid_theta_o ? "grid_theta_o" : "grid_phi_o";
      if (axis->empty()) bad(std::string(name) + " is empty");
      const std::size_t n = axis->size();
      const double step = n > 1 ? (axis->back() - axis->front()) / double(n - 1) : 0.0;
      for (std::size_t i = 0; i < n; ++i)
        if (!std::isfinite((*axis)[i]) || (n > 1 && !(step > 0)) ||
            std::abs((*axis)[i] - (axis->front() + double(i) * step)) > 1e-6 * step)
          bad(std::string(name) + " is not a finite, increasing, uniformly spaced axis (value " + std::to_string(i) + ")");
    }
    if (azimuthal && grid_phi_o.size() != 1)
      bad("azimuthal = true needs one grid_phi_o column (" + std::to_string(grid_phi_o.size()) + " given)");
    if (!azimuthal && grid_phi_o.size() < 2 && !one_omega_o_)
      bad("azimuthal = false needs 2 or more grid_phi_o columns (1 given); a single column is azimuthal symmetry: set "
          "azimuthal = true");
    const std::size_t np = azimuthal ? 1 : grid_phi_o.size();
    std::vector<int> cell(grid_theta_o.size() * np, -1);
    for (std::size_t s = 0; s < slices.size(); ++s) {
      const std::size_t t = nearest(grid_theta_o, slices[s].theta_o);
      const std::size_t p = azimuthal ? 0 : nearest(grid_phi_o, slices[s].phi_o);
      const double dt = grid_theta_o.size() > 1 ? grid_theta_o[1] - grid_theta_o[0] : 1.0;
      const double dp = grid_phi_o.size() > 1 ? grid_phi_o[1] - grid_phi_o[0] : 1.0;
      if (!(std::abs(slices[s].theta_o - grid_theta_o[t]) <= 1e-6 * dt) ||
          (!azimuthal && !(std::abs(slices[s].phi_o - grid_phi_o[p]) <= 1e-6 * dp)))
        bad("slice " + std::to_string(s) + " (theta_o " + std::to_string(slices[s].theta_o) + ", phi_o " +
            std::to_string(slices[s].phi_o) + ") lies on no grid_theta_o x grid_phi_o point");
      int& c = cell[t * np + p];
      if (c >= 0) bad("slices " + std::to_string(c) + " and " + std::to_string(s) + " lie on one grid point");
      c = int(s);
    }
  }

  // The slices serving omega_o and their bilinear weights (thesis eq. 3.7): up to 4
  // (2 with azimuthal symmetry). A file may hold only some slices (every k-th theta_o, or
  // those around some directions): along theta_o, omega_o is then blended linearly between
  // the nearest fitted slices below and above it in its phi_o column (one alone beyond the
  // last); a phi_o column without any fitted slice gives its weight to the other.
  struct Blend {
    int slice[4] = {-1, -1, -1, -1};
    double weight[4] = {0, 0, 0, 0};
    int count = 0;
    double rotate = 0;  // phi_o to add to the sampled phi (azimuthal symmetry)
  };

  // One phi_o column's share of omega_o: weight w, the fitted slices below (lo) and above
  // (hi) it along theta_o and the fraction f of the way from lo to hi; hi < 0 when one
  // slice serves alone.
  struct Column {
    double w = 0;
    int lo = -1, hi = -1;
    double f = 0;
  };

  // The columns serving omega_o (up to 2; 1 with azimuthal symmetry), with the phi weights
  // of those that have a fitted slice (not normalized), and the phi_o to add to sampled
  // phi (azimuthal symmetry).
  int columns(double theta_o, double phi_o, Column out[2], double& rotate) const {
    const Bracket t = bracket(grid_theta_o, theta_o, false);
    Bracket p;
    rotate = 0;
    if (azimuthal) rotate = phi_o;
    else p = bracket(grid_phi_o, wrap_phi(phi_o), true);
    const std::size_t np = azimuthal ? 1 : grid_phi_o.size(), nt = grid_theta_o.size();
    const std::size_t ps[2] = {p.i0, p.i1};
    const double wp[2] = {1 - p.f, p.f};
    const double u = double(t.i0) + t.f;  // the position on the theta_o grid
    int n = 0;
    for (int j = 0; j < (azimuthal ? 1 : 2); ++j) {
      const double w = azimuthal ? 1.0 : wp[j];
      if (w <= 0) continue;
      const std::size_t pj = ps[j];
      // The nearest fitted slices at or below u and at or above it.
      long lo = long(t.i0), hi = long(t.f > 0 ? t.i1 : t.i0);
      while (lo >= 0 && slice_of[std::size_t(lo) * np + pj] < 0) --lo;
      while (hi < long(nt) && slice_of[std::size_t(hi) * np + pj] < 0) ++hi;
      const int s_lo = lo >= 0 ? slice_of[std::size_t(lo) * np + pj] : -1;
      const int s_hi = hi < long(nt) ? slice_of[std::size_t(hi) * np + pj] : -1;
      Column c;
      c.w = w;
      if (s_lo >= 0 && s_hi >= 0 && hi > lo) {
        c.lo = s_lo;
        c.hi = s_hi;
        c.f = (u - double(lo)) / double(hi - lo);
      } else {
        c.lo = s_lo >= 0 ? s_lo : s_hi;
      }
      if (c.lo >= 0) out[n++] = c;
    }
    return n;
  }

  Blend blend(double theta_o, double phi_o) const {
    Blend b;
    Column c[2];
    const int n = columns(theta_o, phi_o, c, b.rotate);
    double total = 0;
    auto add = [&](int s, double w) {
      if (w <= 0 || s < 0) return;
      int k = 0;
      while (k < b.count && b.slice[k] != s) ++k;
      if (k == b.count) {
        b.slice[k] = s;
        ++b.count;
      }
      b.weight[k] += w;
      total += w;
    };
    for (int j = 0; j < n; ++j) {
      if (c[j].hi >= 0) {
        add(c[j].lo, c[j].w * (1 - c[j].f));
        add(c[j].hi, c[j].w * c[j].f);
      } else {
        add(c[j].lo, c[j].w);
      }
    }
    if (b.count == 0) throw std::out_of_range("bsdfmix::mix::MixtureSet: no fitted slice near this omega_o");
    for (int k = 0; k < b.count; ++k) b.weight[k] /= total;
    return b;
  }

  // The mixture that serves omega_o, in the world phi frame (its means rotated by phi_o
  // under azimuthal symmetry): blended() with Interpolation::Blend; with Displace, each
  // column's two slices displaced() the fraction f of the way, the columns then mixed by
  // their weights. pdf_omega, eval_f, eval_rgb and sample of the set are this mixture's;
  // a renderer that queries one omega_o many times builds it once.
  SliceMixture at(double theta_o, double phi_o) const {
    if (interpolation != Interpolation::Displace) return blended(theta_o, phi_o);
    Column c[2];
    double rotate = 0;
    const int n = columns(theta_o, phi_o, c, rotate);
    if (n == 0) throw std::out_of_range("bsdfmix::mix::MixtureSet: no fitted slice near this omega_o");
    SliceMixture pieces[2];
    const SliceMixture* piece[2] = {nullptr, nullptr};
    for (int j = 0; j < n; ++j) {
      if (c[j].hi >= 0 && c[j].f > 0 && c[j].f < 1) {
        pieces[j] = displaced(slices[std::size_t(c[j].lo)], slices[std::size_t(c[j].hi)], plan_up_[std::size_t(c[j].lo)],
                              c[j].f);
        piece[j] = &pieces[j];
      } else {
        piece[j] = &slices[std::size_t(c[j].hi >= 0 && c[j].f >= 1 ? c[j].hi : c[j].lo)];
      }
    }
    const double total = c[0].w + (n > 1 ? c[1].w : 0.0);
    const double w[2] = {c[0].w / total, n > 1 ? c[1].w / total : 0.0};
    return mixed(piece, w, n, rotate, theta_o, phi_o);
  }

  // The uniform share for omega_o: the slices' `defensive` with their blend weights
  // (blend(); with Displace, the same weights of the two slices).
  double defensive(double theta_o, double phi_o) const {
    const Blend b = blend(theta_o, phi_o);
    double a = 0;
    for (int k = 0; k < b.count; ++k) a += b.weight[k] * slices[std::size_t(b.slice[k])].defensive;
    return a;
  }

  // Density over (theta, phi) of what sample() returns for omega_o.
  double pdf_param(double theta_o, double phi_o, double theta, double phi) const {
    if (theta < theta_lo(domain) || theta > theta_hi(domain)) return 0;
    if (interpolation == Interpolation::Displace) return at(theta_o, phi_o).pdf_param(theta, wrap_phi(phi));
    const Blend b = blend(theta_o, phi_o);
    double p = 0;
    for (int k = 0; k < b.count; ++k) p += b.weight[k] * slices[b.slice[k]].pdf_param(theta, wrap_phi(phi - b.rotate));
    return p;
  }

  double pdf_omega(double theta_o, double phi_o, double theta, double phi) const {
    if (map != Map::ThetaPhi) return map_sum(theta_o, phi_o, theta, phi, false);
    const double j = jacobian(domain, theta);
    return j > 0 ? pdf_param(theta_o, phi_o, theta, phi) / j : 0.0;
  }

  // Where eval_f and eval_rgb may be non-zero: the domain, less the horizon of the
  // hemisphere (theta_i = pi/2, where f = (f cos) / cos has nothing left to divide).
  bool f_inside(double theta) const {
    return theta >= theta_lo(domain) && (domain == Domain::Hemisphere ? theta < theta_hi(domain) : theta <= theta_hi(domain));
  }

  // The mixture as a stand-in for f: scale * pdf_omega [/ cos(theta_i) for the hemisphere],
  // each slice with its own scale, blended; 0 outside f_inside.
  double eval_f(double theta_o, double phi_o, double theta, double phi) const {
    if (!f_inside(theta)) return 0;
    if (map != Map::ThetaPhi) {
      const double f = map_sum(theta_o, phi_o, theta, phi, true);
      return domain == Domain::Hemisphere ? f / std::cos(theta) : f;
    }
    const double j = jacobian(domain, theta);
    if (!(j > 0)) return 0;
    double f = 0;
    if (interpolation == Interpolation::Displace) {
      f = at(theta_o, phi_o).eval_param(theta, wrap_phi(phi)) / j;
      return domain == Domain::Hemisphere ? f / std::cos(theta) : f;
    }
    const Blend b = blend(theta_o, phi_o);
    for (int k = 0; k < b.count; ++k) {
      const SliceMixture& s = slices[b.slice[k]];
      f += b.weight[k] * s.scale * s.pdf_param(theta, wrap_phi(phi - b.rotate));
    }
    f /= j;
    if (domain == Domain::Hemisphere) f /= std::cos(theta);
    return f;
  }

  // The stand-in's colour: channel c of f, blended between slices exactly as eval_f; a slice
  // without rgb gives eval_f's value in all three channels.
  void eval_rgb(double theta_o, double phi_o, double theta, double phi, double rgb[3]) const {
    rgb[0] = rgb[1] = rgb[2] = 0;
    if (!f_inside(theta)) return;
    if (map != Map::ThetaPhi) return eval_rgb_map(theta_o, phi_o, theta, phi, rgb);
    const double j = jacobian(domain, theta);
    if (!(j > 0)) return;
    if (interpolation == Interpolation::Displace) {
      at(theta_o, phi_o).eval_rgb_param(theta, wrap_phi(phi), rgb);
      for (int q = 0; q < 3; ++q) rgb[q] /= domain == Domain::Hemisphere ? j * std::cos(theta) : j;
      return;
    }
    const Blend b = blend(theta_o, phi_o);
    for (int k = 0; k < b.count; ++k) {
      const SliceMixture& s = slices[b.slice[k]];
      const double at = wrap_phi(phi - b.rotate);
      if (!s.has_rgb) {  // grey: eval_f's terms, in eval_f's order
        const double f = b.weight[k] * s.scale * s.pdf_param(theta, at);
        for (int q = 0; q < 3; ++q) rgb[q] += f;
        continue;
      }
      double c[3];
      s.eval_rgb_param(theta, at, c);
      for (int q = 0; q < 3; ++q) rgb[q] += b.weight[k] * c[q];
    }
    for (int q = 0; q < 3; ++q) {
      rgb[q] /= j;
      if (domain == Domain::Hemisphere) rgb[q] /= std::cos(theta);
    }
  }

  // A sample for omega_o from four uniforms in [0, 1): u0 picks the slice (Blend), u1 the
  // component, (u2, u3) the point.
  Sample sample(double theta_o, double phi_o, double u0, double u1, double u2, double u3) const {
    if (interpolation == Interpolation::Displace) return at(theta_o, phi_o).sample(domain, u1, u2, u3);
    const Blend b = blend(theta_o, phi_o);
    int k = 0;
    double acc = b.weight[0];
    while (k + 1 < b.count && u0 >= acc) acc += b.weight[++k];
    const SliceMixture& s = slices[b.slice[k]];
    Sample out;
    if (map != Map::ThetaPhi) {
      double x, y;
      s.draw_map(u1, u2, u3, x, y);
      out.valid = from_map(map, x, y, out.theta, out.phi);
      if (out.valid) out.phi = wrap_phi(out.phi + b.rotate);
      out.pdf_omega = out.valid ? pdf_omega(theta_o, phi_o, out.theta, out.phi) : 0.0;
      if (!(out.pdf_omega > 0)) out.valid = false;
      return out;
    }
    const Gaussian& g = s.components[s.pick(u1)];
    double z0, z1;
    normal_pair(u2, u3, z0, z1);
    out.theta = g.mu_t + g.l_tt * z0;
    out.phi = wrap_phi(g.mu_p + g.l_pt * z0 + g.l_pp * z1 + b.rotate);
    out.valid = out.theta >= theta_lo(domain) && out.theta <= theta_hi(domain);
    out.pdf_omega = out.valid ? pdf_omega(theta_o, phi_o, out.theta, out.phi) : 0.0;
    if (!(out.pdf_omega > 0)) out.valid = false;
    return out;
  }

  // The blended mixture of omega_o (thesis eq. 3.7) as one slice mixture in the world
  // phi frame: every component of the blended slices, weighted by its slice's blend
  // weight, its mean rotated by phi_o under azimuthal symmetry. scale is the blended scale;
  // when every blended slice has rgb, so has the result (amplitudes times the blend weights),
  // and when one of them has colour copies, the result's colour holds every slice's colour
  // Gaussians (its copies, or its components).
  SliceMixture blended(double theta_o, double phi_o) const {
    const Blend b = blend(theta_o, phi_o);
    const SliceMixture* piece[4];
    for (int k = 0; k < b.count; ++k) piece[k] = &slices[std::size_t(b.slice[k])];
    return mixed(piece, b.weight, b.count, b.rotate, theta_o, phi_o);
  }

  // The mixture serving omega_o as a set of one slice (at() in the slice frame): queried at
  // omega_o it gives this set's pdf, f and samples, without building at() for each call.
  // For many queries at one omega_o of a set that interpolates by Displace.
  MixtureSet serving(double theta_o, double phi_o) const {
    MixtureSet one;
    one.domain = domain;
    one.map = map;
    one.azimuthal = azimuthal;
    one.grid_theta_o = {theta_o};
    one.grid_phi_o = {azimuthal ? 0.0 : phi_o};
    one.slices = {at(theta_o, azimuthal ? 0.0 : phi_o)};
    one.slices[0].theta_o = theta_o;
    one.slices[0].phi_o = one.grid_phi_o[0];
    one.one_omega_o_ = true;  // one column serves its one phi_o, symmetric or not
    one.prepare();
    return one;
  }

  // Product sampling of omega_o: the mixture serving it (at(), fitted to f J) times a mixture of the
  // lighting over the same (theta, phi) frame (fitted to L alone), so the result follows
  // f L J, the integrand over (theta, phi). Sample it with SliceMixture::sample, weight by
  // its pdf_omega. See product() for the pruning and the outputs.
  SliceMixture product_with(double theta_o, double phi_o, const SliceMixture& lighting, const ProductOptions& o = {},
                            double* mass = nullptr, double* kept = nullptr) const {
    return product(at(theta_o, phi_o), 0.0, lighting, o, mass, kept);
  }

  // Sample `index` of a reproducible stream: sample() fed with uniforms(seed, stream, index).
  Sample sample_counter(double theta_o, double phi_o, std::uint64_t seed, std::uint32_t stream,
                        std::uint64_t index) const {
    double u[4];
    uniforms(seed, stream, index, u);
    return sample(theta_o, phi_o, u[0], u[1], u[2], u[3]);
  }

 private:
  std::vector<Transport> plan_up_;  // per slice: the plan to the next fitted slice above
  bool one_omega_o_ = false;        // serving()'s set: one column without symmetry

  // On an equal-area map: the density per steradian (stand_in false) or the stand-in's
  // f [cos] per steradian (true) of the slices serving omega_o at (theta, phi).
  double map_sum(double theta_o, double phi_o, double theta, double phi, bool stand_in) const {
    if (theta < theta_lo(domain) || theta > theta_hi(domain)) return 0;
    double x, y;
    if (interpolation == Interpolation::Displace) {
      const SliceMixture s = at(theta_o, phi_o);
      to_map(map, theta, phi, x, y);
      return (stand_in ? s.scale : 1.0) * s.pdf_map(x, y);
    }
    const Blend b = blend(theta_o, phi_o);
    to_map(map, theta, wrap_phi(phi - b.rotate), x, y);
    double p = 0;
    for (int k = 0; k < b.count; ++k) {
      const SliceMixture& s = slices[std::size_t(b.slice[k])];
      p += b.weight[k] * (stand_in ? s.scale : 1.0) * s.pdf_map(x, y);
    }
    return p;
  }

  // eval_rgb on an equal-area map.
  void eval_rgb_map(double theta_o, double phi_o, double theta, double phi, double rgb[3]) const {
    const double c = domain == Domain::Hemisphere ? std::cos(theta) : 1.0;
    double x, y;
    if (interpolation == Interpolation::Displace) {
      to_map(map, theta, phi, x, y);
      at(theta_o, phi_o).eval_rgb_map(x, y, rgb);
      for (int q = 0; q < 3; ++q) rgb[q] /= c;
      return;
    }
    const Blend b = blend(theta_o, phi_o);
    to_map(map, theta, wrap_phi(phi - b.rotate), x, y);
    for (int k = 0; k < b.count; ++k) {
      double v[3];
      slices[std::size_t(b.slice[k])].eval_rgb_map(x, y, v);
      for (int q = 0; q < 3; ++q) rgb[q] += b.weight[k] * v[q];
    }
    for (int q = 0; q < 3; ++q) rgb[q] /= c;
  }

  // The mixture of n pieces with weights w, means rotated by `rotate`: every component of
  // every piece, weighted by its piece's weight; scale the weighted scale; with rgb when
  // every piece has it, colour copies when one of them has them (the others' components
  // stand for their colour).
  static SliceMixture mixed(const SliceMixture* const* piece, const double* w, int n, double rotate, double theta_o,
                            double phi_o) {
    SliceMixture out;
    out.theta_o = theta_o;
    out.phi_o = phi_o;
    out.map = piece[0]->map;
    out.defensive = 0;  // the pieces' shares, weighted below
    out.has_rgb = true;
    bool copies = false;
    for (int k = 0; k < n; ++k) copies = copies || !piece[k]->colour.empty();
    for (int k = 0; k < n; ++k) {
      const SliceMixture& s = *piece[k];
      out.scale += w[k] * s.scale;
      out.base += w[k] * s.base;
      for (int c = 0; c < 3; ++c) out.base_rgb[c] += w[k] * s.base_rgb[c];
      out.defensive += w[k] * s.defensive;
      out.has_rgb = out.has_rgb && s.has_rgb;
      for (Gaussian g : s.components) {
        g.weight *= w[k];
        for (double& c : g.rgb) c *= w[k];
        out.components.push_back(rotated(out.map, g, rotate));
      }
      if (copies)
        for (Gaussian g : s.colour.empty() ? s.components : s.colour) {
          for (double& c : g.rgb) c *= w[k];
          out.colour.push_back(rotated(out.map, g, rotate));
        }
    }
    if (!out.has_rgb) out.colour.clear();
    out.prepare();
    return out;
  }

  static std::size_t nearest(const std::vector<double>& axis, double x) {
    std::size_t best = 0;
    for (std::size_t i = 1; i < axis.size(); ++i)
      if (std::abs(axis[i] - x) < std::abs(axis[best] - x)) best = i;
    return best;
  }
};

}  // namespace mix
}  // namespace bsdfmix
