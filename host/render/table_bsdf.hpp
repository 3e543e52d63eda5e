// A tabulated BSDF at a hit, as the renderer uses it (docs/render.md, "Light transport"): a
// fiber's BCSDF (fiber domain) or a measured surface's BRDF (hemisphere domain), both with
// azimuthal symmetry. f from the table (the 4D table in memory, linear between theta_o
// slices, the nearest cell in (theta_i, phi)) or from the mixture stand-in (thesis eqs.
// 3.8-3.11), and the directions drawn by the same samplers as the convergence study:
// uniform, the mixture with a defensive uniform share (the header's MixtureSet::sample
// and pdf_omega, exactly what the study's CPU reference calls), the table CDF, and for a
// measured surface imported from an RGL file the file's own warps (tables/rgl_brdf.hpp,
// as Mitsuba 3 and pbrt-v4 sample it; f stays the table's or the stand-in's). Angles
// in the local frame of the hit, phi from the plane of omega_o (so phi_o = 0, and the
// tables' phi = phi_i - phi_o is phi itself): for a fiber sin(theta) = dot(w, tangent),
// L_o = integral L_i f d(omega); for a surface cos(theta) = dot(w, normal),
// L_o = integral L_i f cos(theta) d(omega).
#pragma once

#include <bsdfmix/mixture.hpp>

#include <cstddef>
#include <string>
#include <vector>

#include "core/color.hpp"
#include "io/table.hpp"
#include "render/cloth.hpp"
#include "render/fast_product.hpp"
#include "render/local_axes.hpp"
#include "sampling/sampling.hpp"

namespace bsdfmix {

class RglBrdf;
namespace render {

struct FullF;

enum class FSource { Table, StandIn };
// BsdfSampler: the material's techniques (sampling/estimator.hpp)

class TableBsdf {
 public:
  // Reads every slice of the (azimuthal) table; `set` may be empty (no mixture
  // samplers, no stand-in) until set_mixture.
  explicit TableBsdf(const std::string& table_path);
  explicit TableBsdf(const TableReader& table);
  void set_mixture(const mix::MixtureSet& set);
  // The RGL file the (hemisphere) table was imported from: BsdfSampler::Rgl samples the
  // light direction with its warps. `rgl` must outlive this object; nullptr: none.
  void set_rgl(const RglBrdf* rgl);
  bool has_rgl() const { return rgl_ != nullptr; }
  // A full-4D table and its stand-in (render/full_f.hpp) give f at fibers instead of this
  // table; the samplers stay this table's. `full` must outlive this object; nullptr: none.
  void set_full(const FullF* full) { full_ = full; }
  const FullF* full() const { return full_; }

  const TableMeta& meta() const { return meta_; }
  std::size_t table_bytes() const { return f_.size() * sizeof(float); }

  // f(theta_o; theta, phi) of the table (linear in theta_o) or of the stand-in: the
  // luminance, and per channel (the table's `rgb` and the mixture's rgb_scale when they
  // are there; otherwise the luminance in every channel).
  double f(FSource which, double theta_o, double theta, double phi) const;
  Rgb f_rgb(FSource which, double theta_o, double theta, double phi) const;
  bool has_rgb() const { return !rgb_.empty(); }

  // A direction (theta, phi) from uniforms u[0..3] and its density per steradian;
  // pdf 0: no sample. The mixture sampler is the mixture with share(theta_o) of
  // uniform samples (balance heuristic), as mis_tab.
  void sample(BsdfSampler s, double theta_o, const double u[4], double& theta, double& phi, double& pdf) const;
  double pdf(BsdfSampler s, double theta_o, double theta, double phi) const;
  // The mixture sampler's uniform share: this number, or below 0 the mixture file's earned
  // share at theta_o (share()).
  double uniform_fraction = 0.1;
  // The uniform share at theta_o: uniform_fraction, or the earned one (MixtureSet::defensive
  // when a fitted slice brackets theta_o, else the nearest fitted slice's).
  double share(double theta_o) const;

  // The mixture's own sampler and density at theta_o: the header's MixtureSet::sample
  // and pdf_omega at (theta_o, 0) when a fitted slice brackets theta_o, else the nearest
  // fitted slice's mixture.
  mix::Sample mixture_sample(double theta_o, const double u[4]) const;
  double mixture_pdf(double theta_o, double theta, double phi) const;

  // The plane of the mixtures' components (mixture.hpp, "Maps").
  mix::Map map() const { return set_.map; }
  // The mixture of the fitted slice nearest theta_o times `lighting`, a mixture over the
  // same plane (map()) of the hit's frame: the header's product, pruned by `o`.
  // Throws std::invalid_argument when the two do not overlap.
  mix::SliceMixture product(double theta_o, const mix::SliceMixture& lighting, const mix::ProductOptions& o) const;
  // The same slice's mixture as the renderer's per-vertex product reads it
  // (render/fast_product.hpp).
  const ProductFactor& product_factor(double theta_o) const;

 private:
  void bracket(double theta_o, std::size_t& i0, std::size_t& i1, double& w) const;
  int nearest_fitted(double theta_o) const;
  bool bracketed(double theta_o) const;
  double cell_f(std::size_t slice, double theta, double phi) const;
  // The cell index of (theta, phi) within a slice, or -1 outside theta's range.
  long cell_of(double theta, double phi) const;

  TableMeta meta_;
  std::vector<float> f_;          // [theta_o][theta_i][phi_i]
  std::vector<float> rgb_;        // [theta_o][theta_i][phi_i][3] when the table has `rgb`
  std::vector<CellCdf> cdf_;      // per theta_o slice
  std::vector<double> cell_w_;    // per theta_i row: integral of J over a cell
  double th0_ = 0, dth_ = 0, ph0_ = 0, dph_ = 0, to0_ = 0, dto_ = 0;
  double uniform_pdf_ = 0;       // uniform sampling's density: 1 / (4 pi) or 1 / (2 pi)
  int product_slice(double theta_o) const;
  mix::MixtureSet set_;
  std::vector<ProductFactor> factors_;  // per slice of set_
  bool has_set_ = false;
  bool set_has_rgb_ = false;      // some slice of the mixtures has rgb amplitudes
  std::vector<int> fitted_;       // per theta_o grid slice: index into set_.slices, -1
  const RglBrdf* rgl_ = nullptr;  // BsdfSampler::Rgl's warps
  const FullF* full_ = nullptr;   // f at fibers from a full-4D table
};

// A hit's frame for a tabulated material: the axis (a fiber's tangent: sin(theta) =
// dot(w, axis); a surface's shading normal: cos(theta) = dot(w, axis)) and the plane of
// omega_o (phi = 0 along its part across the axis), omega_o's theta in the domain's
// convention.
struct HitFrame {
  LocalAxes a;
  double theta_o = 0;
  HitFrame(const Vec3& axis, const Vec3& wo, Domain domain);
  const LocalAxes& axes() const { return a; }
  void to_local(const Vec3& w, double& theta, double& phi) const { local_angles(a, w, theta, phi); }
  Vec3 to_world(double theta, double phi) const { return local_direction(a, theta, phi); }
};

}  // namespace render
}  // namespace bsdfmix
