// The incident radiance a path guide learns (docs/render.md, "Guided paths"): a kd-tree
// over the positions of path vertices, and in each leaf a Gaussian mixture of the
// radiance arriving there, over world directions. The directions are the fiber domain's
// latitude-longitude about the horizontal axis +x (theta = asin(w_x) in [-pi/2, pi/2],
// phi = atan2(-w_y, w_z): phi = 0 is the zenith, +-pi the nadir), so that the zenith,
// where a sky is brightest, lies on the map's equator, far from its poles. A leaf's training samples are
// binned to a directional grid, each cell holding the estimate of the integral of the
// incident luminance over its solid angle, and the leaves are fitted as the slices of one
// sweep: the weighted EM kernels and the Gaussian-count search that fit table slices. So
// a leaf's mixture, as a density over (theta, phi), follows L_i cos(theta): per steradian
// it follows L_i.
#pragma once

#include <bsdfmix/mixture.hpp>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "core/domain.hpp"
#include "core/vec3.hpp"
#include "device/device.hpp"
#include "fit/em.hpp"
#include "sweep/fit_settings.hpp"

namespace bsdfmix {
namespace guide {

// One training sample of a path vertex: the luminance that arrived at `position` from
// the direction (theta, phi) of the guide's map (`radiance`), the density the direction
// was drawn with (`pdf`, per steradian), and at that direction the vertex's scattering
// (`f`: the luminance of f cos, or f at a fiber) and its own sampler's density
// (`pdf_bsdf`). What arrives straight from the lighting counts with its MIS weight
// against light sampling, so that the guide learns what light sampling leaves to the
// directions a vertex draws (Karlik et al. 2019, "MIS compensation").
struct Sample {
  float position[3];
  float theta, phi;
  float radiance, pdf, f, pdf_bsdf;
  // the sample's share of the integral of the incident luminance over directions
  double value() const { return pdf > 0 ? double(radiance) / double(pdf) : 0.0; }
};

// A world direction's (theta, phi) in the guide's map, and back.
inline void guide_angles(const Vec3& w, double& theta, double& phi) {
  theta = std::asin(std::clamp(w[0], -1.0, 1.0));
  phi = std::atan2(-w[1], w[2]);
}
inline Vec3 guide_direction(double theta, double phi) {
  const double c = std::cos(theta);
  return {std::sin(theta), -c * std::sin(phi), c * std::cos(phi)};
}

struct FieldSettings {
  int grid_theta = 16, grid_phi = 32;  // a leaf's directional grid over the sphere
  std::size_t leaf_samples = 16384;    // a node holding more samples (path vertices) is split
  std::size_t min_vertices = 256;      // a leaf with fewer has no mixture (the BSDF samples there)
  int max_depth = 24;                  // of the tree
  double compact_sigma = 0.5;          // components this compact (sigma_max, radians) are carried
  double share = 0.5;                  // the largest share of a vertex's directions drawn from the guide
  bool adapt_share = true;             // each leaf picks its share (Leaf::share); false: every leaf takes `share`
  FitSettings fit;                     // the leaves' sweep settings (output paths unused)
};

// A leaf's fitted radiance: the mixture over world (theta, phi), prepared, and the
// components compact enough to carry into a local frame (render/light_carry.hpp), their
// weights divided by cos(theta) at their means so that they follow L_i over (theta, phi)
// as the world lighting's mixture does.
struct Leaf {
  mix::SliceMixture mixture;
  // The share of a vertex's directions drawn from the guide here: of 0, 1/8, ..., 1 times
  // FieldSettings::share, the one whose one-sample MIS estimate of the leaf's samples'
  // scattered light, f L / (share p_guide + (1 - share) p_bsdf), has the least second
  // moment (estimated from the samples, each weighted by its own density): where the guide
  // would add variance, it is not used.
  double share = 0;
  std::vector<mix::Gaussian> compact;
  double compact_share = 0;  // the compact components' share of the mixture's weight
};

class RadianceField {
 public:
  // No leaf: at() is null everywhere.
  RadianceField() = default;

  // Learns the field from `samples` (reordered): builds the tree over the vertices'
  // positions and fits every leaf with enough vertices on `devices`, the engine run as
  // `engine` says.
  void learn(std::vector<Sample>& samples, const FieldSettings& s, const std::vector<Device>& devices,
             const std::string& what, const EngineOptions& engine = {});

  // The leaf mixture at `p`, or null where the leaf has none.
  const Leaf* at(const Vec3& p) const;

  std::size_t leaves() const { return leaf_of_node_count_; }
  std::size_t fitted() const { return fitted_; }
  std::size_t guiding() const { return guiding_; }  // leaves whose share is above 0
  double mean_k() const;
  double fit_seconds() const { return fit_seconds_; }

 private:
  struct Node {
    int axis = -1;  // -1: a leaf
    float split = 0;
    int child = 0;  // the first child; the second is child + 1
    int leaf = -1;  // a leaf's index into leaves_ (-1: no mixture)
  };
  // A leaf to fit: its samples [begin, end) of the reordered array and its node.
  struct Span {
    std::size_t begin, end;
    int node;
  };
  // The tree over `samples` (reordered): a node holding more than leaf_samples vertices is
  // split at the median of its samples along the longest side of their bounding box; the
  // leaves with at least min_vertices, to fit.
  std::vector<Span> build_tree(std::vector<Sample>& samples, const FieldSettings& s);
  // The leaves' grids fitted as one sweep, and each fitted leaf's mixture, share and
  // compact components; a leaf whose fit failed has none.
  void fit_leaves(const std::vector<Sample>& samples, const std::vector<Span>& spans, const FieldSettings& s,
                  const std::vector<Device>& devices, const std::string& what, const EngineOptions& engine);

  std::vector<Node> nodes_;
  std::vector<Leaf> leaves_;
  std::size_t leaf_of_node_count_ = 0, fitted_ = 0, guiding_ = 0;
  double fit_seconds_ = 0;
};

// Leaf::share for `guide` over the samples [begin, end), of 0, 1/8, ..., 1 times `largest`.
double best_share(const mix::SliceMixture& guide, const Sample* begin, const Sample* end, double largest);

// The estimate a leaf's grid holds: per cell the sum of the values of the samples in it
// over the leaf's samples, [theta][phi] with theta rows from -pi/2 up and phi columns
// from -pi; the cell a direction falls in by its (theta, phi).
std::vector<double> bin_leaf(const Sample* begin, const Sample* end, int grid_theta, int grid_phi);

}  // namespace guide
}  // namespace bsdfmix
