// Evaluation of a measured BRDF of the RGL material database (Dupuy & Jakob 2018,
// "An adaptive parameterization for efficient material acquisition and rendering").
//
// Direction convention (docs/formats.md, "RGL tables"): the file's tabulated direction
// (its theta_i/phi_i parameter axes; Mitsuba's si.wi, pbrt-v4's wo) is the view direction, our omega_o.
// The direction the file's warps produce (Mitsuba's wo) is the light direction, our
// omega_i. f = (measured value) * D(wm) / (4 sigma(omega_o)) / cos(theta_i): Mitsuba's
// `eval` divided by the cosine of the light direction, pbrt-v4's MeasuredBxDF::f.
#pragma once

#include <array>
#include <cstddef>
#include <string>
#include <vector>

#include "core/color.hpp"

namespace bsdfmix {

class RglFile;

// A piecewise-bilinear function on [0, 1]^2 sampled on an nx x ny grid of nodes
// (x the contiguous axis), one grid per combination of parameter values, linearly
// interpolated between parameter values (clamped at the ends). Built as a density
// (normalized per grid, with the marginal-conditional CDFs that invert it) or as a
// plain interpolant.
class RglWarp2D {
 public:
  RglWarp2D() = default;
  // data: [param 0][param 1]...[ny][nx]; params: the value of each parameter axis.
  RglWarp2D(const std::vector<double>& data, std::size_t nx, std::size_t ny,
            std::vector<std::vector<double>> params, bool density);

  // The interpolant (plain) or the density on [0, 1]^2 (density) at (x, y).
  double eval(double x, double y, const double* param = nullptr) const;
  // Density only: the point of [0, 1]^2 that the sampling map sends to (x, y), that is
  // the conditional-marginal CDF pair (conditional in x, marginal in y), and the density there.
  std::array<double, 3> invert(double x, double y, const double* param = nullptr) const;
  // Density only: the sampling map itself, [0, 1]^2 -> [0, 1]^2, and the density there.
  std::array<double, 3> sample(double u, double v, const double* param = nullptr) const;

 private:
  struct Corner {
    std::size_t slice;
    double weight;
  };
  // The grid cell around (x, y) for the parameters: its corners' interpolation weights,
  // the position inside it and the four data values.
  struct Cell {
    Corner c[8];
    int nc;
    std::size_t ix, iy, i;
    double fx, fy, v00, v10, v01, v11;
  };
  int corners(const double* param, Corner* out) const;
  Cell cell_at(double x, double y, const double* param) const;
  double lookup(const std::vector<double>& a, std::size_t stride, std::size_t index, const Corner* c,
                int n) const;

  std::size_t nx_ = 0, ny_ = 0;
  bool density_ = false;
  std::vector<std::vector<double>> params_;
  std::vector<double> data_, cond_cdf_, marg_cdf_;
};

// f of a measured BRDF: luminance and RGB (sr^-1).
struct RglValue {
  double y = 0.0;                  // 0.2126 R + 0.7152 G + 0.0722 B
  std::array<double, 3> rgb{};     // as measured (may hold small negative noise)
};

class RglBrdf {
 public:
  // Reads the file and checks every field the evaluation uses; throws InputError
  // "<path>: <problem>" on a malformed or unsupported (anisotropic, spectral) file.
  explicit RglBrdf(const std::string& path);

  const std::string& path() const { return path_; }
  const std::string& description() const { return description_; }
  const std::string& sha256() const { return sha256_; }
  std::size_t n_theta() const { return theta_axis_.size(); }  // tabulated view elevations
  std::size_t resolution() const { return res_; }            // nodes per side of the RGB grids
  // Values of the non-negative fields (ndf, sigma, vndf, luminance) that lay within float
  // rounding below zero and were read as 0.
  std::size_t rounding_zeros() const { return rounding_zeros_; }

  // f for the view direction omega_o and the light direction omega_i (unit vectors in
  // the local frame, z the normal). Zero below the horizon (either cosine <= 0).
  RglValue eval(const std::array<double, 3>& omega_o, const std::array<double, 3>& omega_i) const;
  // The same from spherical angles (theta from the normal, phi azimuth).
  RglValue eval(double theta_o, double phi_o, double theta_i, double phi_i) const;
  // The density (per solid angle of omega_i) with which the file's warps sample the
  // light direction for the view direction omega_o: luminance warp, then VNDF warp
  // (Mitsuba's `pdf`). Its integral over the upper hemisphere is <= 1.
  double pdf(const std::array<double, 3>& omega_o, const std::array<double, 3>& omega_i) const;
  // Samples a light direction for the view omega_o from (u1, u2) in [0, 1)^2 with the
  // warps (Mitsuba's `sample`). `valid` is false when it falls below the horizon.
  struct Sample {
    std::array<double, 3> omega_i{};
    double pdf = 0.0;
    bool valid = false;
  };
  Sample sample(const std::array<double, 3>& omega_o, double u1, double u2) const;

 private:
  std::string path_, description_, sha256_;
  std::vector<double> theta_axis_;
  std::size_t res_ = 0;
  std::size_t rounding_zeros_ = 0;
  bool jacobian_ = true;
  RglWarp2D ndf_, sigma_, vndf_, luminance_, rgb_;
};

// Luminance of linear sRGB/Rec.709 primaries (core/color.hpp).
inline double rgb_luminance(double r, double g, double b) { return rec709_luminance(r, g, b); }

}  // namespace bsdfmix
