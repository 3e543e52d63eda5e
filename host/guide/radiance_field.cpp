// The radiance field: the kd-tree over vertex positions, the leaves' grids and their fit.
#include "guide/radiance_field.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "core/progress.hpp"
#include "io/mixture_file.hpp"
#include "sweep/fit_slices.hpp"
#include "sweep/slice_source.hpp"

namespace bsdfmix {
namespace guide {

namespace {

constexpr double kClamp = 100;

// A node's samples, [begin, end) of the reordered sample array, and its depth.
struct Range {
  std::size_t begin, end;
  int depth, node;
};

// The leaves' grids as the slices of one sweep: slice i is leaf i's grid over the guide's
// map (the fiber domain's (theta, phi)), its weights the cell estimates themselves (the
// integral of L_i over the cell's solid angle is what the mixture's density over (theta,
// phi) integrates to, cell by cell).
class LeafSlices final : public SliceSource {
 public:
  LeafSlices(std::vector<std::vector<double>> grids, int gt, int gp)
      : meta_(make_grid(Domain::Fiber, grids.size(), 1, std::size_t(gt), std::size_t(gp), true)),
        grids_(std::move(grids)) {
    meta_.rgb = false;
    meta_.source = "{\"guide\": \"incident radiance of a leaf, integral over each cell's solid angle\"}";
  }
  const TableMeta& meta() const override { return meta_; }
  std::vector<double> weights(const SliceRef& ref) const override { return grids_[ref.t_o]; }

 private:
  TableMeta meta_;
  std::vector<std::vector<double>> grids_;
};

// A leaf's mixture from slice `slice` of the fitted leaves, no component narrower than a
// grid cell (narrower ones are the noise of a cell or two), prepared; false when it is no
// mixture (a covariance or the weights degenerate).
bool leaf_mixture(const MixtureFile& fitted, std::size_t slice, const FieldSettings& s, mix::SliceMixture& out) {
  try {
    out = slice_mixture(fitted, slice);
    const double ct = kPi / s.grid_theta, cp = 2 * kPi / s.grid_phi;
    for (mix::Gaussian& g : out.components) {
      const double rho = g.s_tp / std::sqrt(g.s_tt * g.s_pp);
      g.s_tt = std::max(g.s_tt, ct * ct);
      g.s_pp = std::max(g.s_pp, cp * cp);
      g.s_tp = rho * std::sqrt(g.s_tt * g.s_pp);
    }
    out.prepare();
  } catch (const std::invalid_argument&) {
    return false;
  }
  return true;
}

}  // namespace

double best_share(const mix::SliceMixture& guide, const Sample* begin, const Sample* end, double largest) {
  constexpr int kSteps = 8;
  double moment[kSteps + 1] = {};
  for (const Sample* s = begin; s != end; ++s) {
    if (!(s->pdf > 0) || !(s->f > 0) || !(s->radiance > 0)) continue;
    const double pg = guide.pdf_omega(Domain::Fiber, s->theta, s->phi), fl = double(s->f) * double(s->radiance);
    for (int k = 0; k <= kSteps; ++k) {
      const double a = largest * k / kSteps, p = a * pg + (1 - a) * double(s->pdf_bsdf);
      // E_draw[(f L / p)^2 p / p_draw]: the second moment under p, from samples drawn by p_draw
      moment[k] += p > 0 ? fl * fl / (p * double(s->pdf)) : std::numeric_limits<double>::infinity();
    }
  }
  int best = 0;
  for (int k = 1; k <= kSteps; ++k)
    if (moment[k] < moment[best]) best = k;
  return largest * best / kSteps;
}

std::vector<double> bin_leaf(const Sample* begin, const Sample* end, int grid_theta, int grid_phi) {
  std::vector<double> g(std::size_t(grid_theta) * std::size_t(grid_phi), 0.0);
  const std::size_t n = std::size_t(end - begin);
  if (n == 0) return g;
  // Paths through near-lossless fibers make heavy-tailed estimates: a few samples would
  // each make a cell, and a component, of their own. Values are capped at kClamp times
  // the leaf's mean sample value (the guide is a proposal: this costs no bias).
  double mean = 0;
  for (const Sample* s = begin; s != end; ++s) mean += std::max(0.0, s->value());
  const double cap = kClamp * mean / double(n);
  for (const Sample* s = begin; s != end; ++s) {
    const double v = s->value();
    if (!(v > 0)) continue;
    const int i = std::clamp(int((s->theta + kPi / 2) / kPi * grid_theta), 0, grid_theta - 1);
    const int j = std::clamp(int((s->phi + kPi) / (2 * kPi) * grid_phi), 0, grid_phi - 1);
    g[std::size_t(i) * std::size_t(grid_phi) + std::size_t(j)] += std::min(v, cap);
  }
  for (double& v : g) v /= double(n);
  return g;
}

void RadianceField::learn(std::vector<Sample>& samples, const FieldSettings& s, const std::vector<Device>& devices,
                          const std::string& what, const EngineOptions& engine) {
  const auto t0 = std::chrono::steady_clock::now();
  nodes_.assign(1, Node{});
  leaves_.clear();
  leaf_of_node_count_ = fitted_ = guiding_ = 0;
  const std::vector<Span> spans = build_tree(samples, s);
  fit_leaves(samples, spans, s, devices, what, engine);
  fit_seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

std::vector<RadianceField::Span> RadianceField::build_tree(std::vector<Sample>& samples, const FieldSettings& s) {
  std::vector<Range> todo{{0, samples.size(), 0, 0}};
  std::vector<Span> spans;
  while (!todo.empty()) {
    const Range r = todo.back();
    todo.pop_back();
    Sample* b = samples.data() + r.begin;
    Sample* e = samples.data() + r.end;
    const std::size_t nv = r.end - r.begin;
    int axis = -1;
    if (nv > s.leaf_samples && r.depth < s.max_depth) {
      float lo[3] = {1e30f, 1e30f, 1e30f}, hi[3] = {-1e30f, -1e30f, -1e30f};
      for (const Sample* q = b; q != e; ++q)
        for (int a = 0; a < 3; ++a) {
          lo[a] = std::min(lo[a], q->position[a]);
          hi[a] = std::max(hi[a], q->position[a]);
        }
      axis = 0;
      for (int a = 1; a < 3; ++a)
        if (hi[a] - lo[a] > hi[axis] - lo[axis]) axis = a;
      if (!(hi[axis] > lo[axis])) axis = -1;
    }
    if (axis < 0) {
      ++leaf_of_node_count_;
      if (nv >= s.min_vertices) {
        nodes_[std::size_t(r.node)].leaf = int(spans.size());
        spans.push_back({r.begin, r.end, r.node});
      }
      continue;
    }
    Sample* mid = b + (e - b) / 2;
    std::nth_element(b, mid, e, [axis](const Sample& x, const Sample& y) { return x.position[axis] < y.position[axis]; });
    const float split = mid->position[axis];
    // everything below the split value to the left, so that lookups agree with the partition
    Sample* cut = std::partition(b, e, [axis, split](const Sample& q) { return q.position[axis] < split; });
    if (cut == b || cut == e) {  // every sample on one side of the median (many equal positions): a leaf
      todo.push_back({r.begin, r.end, s.max_depth, r.node});
      continue;
    }
    const int child = int(nodes_.size());
    nodes_.resize(nodes_.size() + 2);
    nodes_[std::size_t(r.node)].axis = axis;
    nodes_[std::size_t(r.node)].split = split;
    nodes_[std::size_t(r.node)].child = child;
    const std::size_t c = std::size_t(cut - samples.data());
    todo.push_back({c, r.end, r.depth + 1, child + 1});
    todo.push_back({r.begin, c, r.depth + 1, child});
  }
  return spans;
}

void RadianceField::fit_leaves(const std::vector<Sample>& samples, const std::vector<Span>& spans,
                               const FieldSettings& s, const std::vector<Device>& devices, const std::string& what,
                               const EngineOptions& engine) {
  std::vector<std::vector<double>> grids;
  grids.reserve(spans.size());
  for (const Span& span : spans)
    grids.push_back(bin_leaf(samples.data() + span.begin, samples.data() + span.end, s.grid_theta, s.grid_phi));
  leaves_.resize(grids.size());
  if (grids.empty()) return;
  const std::size_t n = grids.size();
  const LeafSlices source(std::move(grids), s.grid_theta, s.grid_phi);
  std::vector<SliceRef> refs;
  for (std::size_t i = 0; i < n; ++i) refs.push_back({i, i, 0});
  // The leaves are fitted over (theta, phi) whatever the settings' map: the cell floor of
  // leaf_mixture is in radians, and the compact components are carried as (theta, phi)
  // lobes (render/light_carry.hpp).
  FitSettings fit = s.fit;
  fit.map = "theta_phi";
  const SweepResult fitted = fit_slices(source, refs, fit, devices, what, engine);
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t slice = std::size_t(std::find(fitted.slice_index.begin(), fitted.slice_index.end(), i) -
                                          fitted.slice_index.begin());
    Leaf& leaf = leaves_[i];
    if (slice >= fitted.mixture.slices() || fitted.mixture.k[slice] <= 0 || fitted.report[slice].failed() ||
        !leaf_mixture(fitted.mixture, slice, s, leaf.mixture)) {
      nodes_[std::size_t(spans[i].node)].leaf = -1;
      continue;
    }
    ++fitted_;
    leaf.share = s.adapt_share ? best_share(leaf.mixture, samples.data() + spans[i].begin,
                                            samples.data() + spans[i].end, s.share)
                               : s.share;
    if (leaf.share > 0) ++guiding_;
    for (const mix::Gaussian& g : leaf.mixture.components) {
      if (g.sigma_max() > s.compact_sigma) continue;
      mix::Gaussian c = g;
      c.weight = g.weight / std::max(std::cos(g.mu_t), 0.05);
      leaf.compact.push_back(c);
      leaf.compact_share += g.weight;
    }
  }
}

const Leaf* RadianceField::at(const Vec3& p) const {
  if (nodes_.empty()) return nullptr;
  const Node* n = &nodes_.front();
  while (n->axis >= 0) n = &nodes_[std::size_t(n->child + (float(p[std::size_t(n->axis)]) < n->split ? 0 : 1))];
  return n->leaf >= 0 ? &leaves_[std::size_t(n->leaf)] : nullptr;
}

double RadianceField::mean_k() const {
  double k = 0;
  std::size_t n = 0;
  for (const Node& node : nodes_)
    if (node.axis < 0 && node.leaf >= 0) {
      k += double(leaves_[std::size_t(node.leaf)].mixture.components.size());
      ++n;
    }
  return n ? k / double(n) : 0.0;
}

}  // namespace guide
}  // namespace bsdfmix
