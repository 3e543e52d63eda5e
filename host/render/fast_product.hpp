// mis_product's product at a path vertex, made cheap (docs/render.md, "Product sampling"):
// the lighting's compact components carried into the hit's frame (render/light_carry.hpp)
// times the BSDF mixture of the slice nearest theta_o, built into buffers a thread reuses
// from vertex to vertex (no allocation once they have grown), in float, structure of
// arrays. Nearly the mixture of the header's product() (mix::product: one component per
// pair and phi image, heaviest first until `keep` of the mass, at most max_components),
// with three differences that change which components are kept, never the density of
// what is sampled:
//  - a pair's weight is computed for the three phi images nearest its means alone
//    (farther images are pruned; the header sums up to 9 sigma);
//  - the pairs are not sorted: those kept are the heaviest, found by buckets of their
//    float exponent, all but whole buckets of the lightest that hold together at most
//    1 - keep of the mass (so the header's pairs and at most those within a factor 2 of
//    its lightest), cut to the heaviest max_components by a selection;
//  - on a surface, lighting components more than 4 of their standard deviations below
//    the horizon are left out before the pairs (they light nothing there; light sampling
//    covers them in the MIS).
// pdf_omega is the exact density (to float rounding, relative 1e-6) of what sample()
// draws: the same float parameters serve both, summed over every phi image within 9
// sigma, as the header's Gaussian::density.
#pragma once

#include <bsdfmix/mixture.hpp>

#include <cstddef>
#include <vector>

#include "render/local_axes.hpp"

namespace bsdfmix {
namespace render {

// A prepared slice mixture as the pairs read it: weights, means (phi wrapped into
// [-pi, pi)), covariances and precisions, one float array each, and the map of its plane.
// A Lambertian base takes part as mix::product takes it (mix::product_parts).
struct ProductFactor {
  std::vector<float> w, mt, mp, stt, stp, spp, itt, itp, ipp;
  mix::Map map = mix::Map::ThetaPhi;
  void assign(const mix::SliceMixture& s);
  std::size_t size() const { return w.size(); }
};

// The world lighting's compact components ready to carry: each one's direction and its
// derivatives along the source map's theta and phi (what carry_lighting recomputes with
// trigonometry at every hit), its covariance, weight and largest standard deviation.
struct CarrySource {
  struct Lobe {
    Vec3 w, dwt, dwp;
    double s_tt, s_tp, s_pp, weight, sigma_max;
  };
  std::vector<Lobe> lobes;
  CarrySource() = default;
  explicit CarrySource(const std::vector<mix::Gaussian>& compact, const LocalAxes& from = kWorldAxes);
  bool empty() const { return lobes.empty(); }
};

class FastProduct {
 public:
  // The product of the lighting `src` carried into the frame `f` with `bsdf`, in the plane
  // of bsdf's map (its (x, y) as (theta, phi) below); false (and empty) when they do not
  // overlap.
  bool build(const ProductFactor& bsdf, const CarrySource& src, const LocalAxes& f, const mix::ProductOptions& o);
  std::size_t size() const { return w_.size(); }
  // As SliceMixture::sample and pdf_omega: invalid when theta leaves the domain (on a
  // map's plane: when the point leaves the map, mix::from_map).
  mix::Sample sample(Domain d, double u1, double u2, double u3) const;
  double pdf_omega(Domain d, double theta, double phi) const;
  // The components as header Gaussians, prepared (for tests).
  mix::SliceMixture mixture() const;

 private:
  // The steps of build: the lighting carried into the frame (lw_ ... lipp_); the
  // candidates kept (order_'s first entries, their count returned); their Gaussians (the
  // sum of their weights returned); the normalized weights, CDF and wide components.
  void carry_lighting(const CarrySource& src, const LocalAxes& f);
  std::size_t keep_heaviest(double total, const mix::ProductOptions& o);
  double add_pairs(const ProductFactor& a, std::size_t top);
  void normalize(double acc);
  // The density per unit of the plane at (t, p), p in [-pi, pi).
  double pdf_plane(float t, float p) const;

  // the carried lighting: weight, mean, covariance, precision
  std::vector<float> lw_, lmt_, lmp_, ltt_, ltp_, lpp_, litt_, litp_, lipp_;
  // candidates: weight per (image k, lighting j, bsdf i), index (k n_light + j) n_bsdf + i
  std::vector<float> cand_;
  std::vector<std::pair<float, int>> order_;
  // the product's components: normalized weight, the same over 2 pi det(L), mean, the
  // inverse Cholesky factor's diagonal, the Cholesky factor L, the CDF, and those wide enough in phi to need images beyond the nearest three
  std::vector<float> w_, wn_, mt_, mp_, itt_, ipp_, ctt_, cpt_, cpp_, cdf_;
  std::vector<int> wide_;
  std::vector<float> wide_cut_;
  mix::Map map_ = mix::Map::ThetaPhi;  // the plane of the product: the bsdf factor's
  mutable std::vector<float> term_;  // pdf_omega's per-component terms (one thread uses a product)
};

}  // namespace render
}  // namespace bsdfmix
