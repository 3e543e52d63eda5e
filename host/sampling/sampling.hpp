// Importance sampling from a mixture file and the Monte Carlo estimators of the
// convergence study: the problem of one omega_o (the blended table slice, its CDF, the
// blended mixture flattened for the kernels, the lighting), the device drivers of
// kernels/sample.cl and their CPU references (host/sampling/sample_reference.cpp).
#pragma once

#include <bsdfmix/mixture.hpp>

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/domain.hpp"
#include "device/device.hpp"
#include "io/table.hpp"
#include "sampling/estimator.hpp"
#include "sampling/light_sampler.hpp"
#include "sampling/lighting.hpp"

namespace bsdfmix {

class RglBrdf;

// Counter streams (third counter word): sample CLI and each estimator.
constexpr std::uint32_t kSampleStream = mix::kSampleStream;  // "samp", the header's
std::uint32_t estimator_stream(int estimator);

// ---- the mixture serving one omega_o, flattened (kernels/sample.cl layout) -----------

struct QueryMixture {
  static constexpr std::size_t kQuery = 32;  // floats in q
  static constexpr std::size_t kLanes = 8;   // components per pdf block (kernels/sample.cl PDF_LANES)
  static constexpr std::size_t kRows = 8;    // float8 rows per pdf block
  Domain domain = Domain::Fiber;
  mix::Map map = mix::Map::ThetaPhi;  // the plane of the components (kernels/sample.cl MAP)
  mix::MixtureSet::Blend blend;
  // count, rotate, weights, first, counts, total, pdf blocks, broad blocks, extra
  // images, search step, cumulative weights (kernels/sample.cl, Q_*)
  std::vector<float> q;
  std::vector<float> comps;  // 16 floats per component: the draw (and the reference layout)
  std::vector<float> pdf;    // pdf blocks, then broad blocks: kRows x kLanes floats each
  std::size_t components() const { return comps.size() / 16; }
};

// f_unit divides the stand-in's values (component [9], scale x density) before they are
// rounded to float: the estimator launches pass the power of two they scale f by.
QueryMixture make_query(const mix::MixtureSet& set, double theta_o, double phi_o, double f_unit = 1.0);
// One slice mixture on its own (a product mixture), phi in the world frame.
QueryMixture make_query(const mix::SliceMixture& mixture, Domain domain);

// ---- sampling --------------------------------------------------------------------------

// Samples first..first+n-1 of `stream` under `seed` on a device (float) ...
std::vector<mix::Sample> sample_device(const Device& device, const mix::MixtureSet& set, double theta_o,
                                       double phi_o, std::uint64_t seed, std::uint32_t stream, std::uint64_t first,
                                       std::size_t n);
// ... and on the CPU with the renderer-facing header (double): the reference.
std::vector<mix::Sample> sample_cpu(const mix::MixtureSet& set, double theta_o, double phi_o, std::uint64_t seed,
                                    std::uint32_t stream, std::uint64_t first, std::size_t n);

// pdf_omega and the stand-in f at directions (theta, phi), on a device: pairs (pdf, f).
std::vector<std::pair<double, double>> eval_device(const Device& device, const mix::MixtureSet& set, double theta_o,
                                                   double phi_o, const std::vector<std::pair<double, double>>& dirs);

// ---- estimators ------------------------------------------------------------------------

// us_tab .. mis_product (0 .. 10): the estimators kernels/sample.cl implements (their
// device_id, sampling/estimator.hpp). The others run on the CPU alone (integrate_cpu).
constexpr int kDeviceEstimators = 11;

// The table as f for one omega_o: the blend of the table slices serving omega_o with
// the mixture's bilinear weights, piecewise constant over its cells (phi in the slice
// frame: with azimuthal symmetry the query's phi_o rotates it).
struct TableSlice {
  Domain domain = Domain::Fiber;
  std::vector<float> f;  // [n_theta][n_phi]
  std::size_t n_theta = 0, n_phi = 0;
  double th0 = 0, dth = 0, ph0 = 0, dph = 0;  // lower edge of the first cell, cell size
  double rotate = 0;
  double theta_edge(std::size_t i) const;  // clamped to the domain
  double f_at(double theta, double phi_world) const;
  // Integral over cell (i, j) of cos(theta) [hemisphere only] J(theta) dtheta dphi, and of J alone.
  double cell_weight(std::size_t i) const;
  double cell_solid_angle(std::size_t i) const;
};

TableSlice blended_slice(const TableReader& table, const mix::MixtureSet& set, double theta_o, double phi_o);

// Piecewise-constant 2D CDF over the cells, proportional to f * cell_weight.
struct CellCdf {
  std::vector<float> marginal;     // [n_theta + 1]
  std::vector<float> conditional;  // [n_theta][n_phi + 1]
};
CellCdf build_cdf(const TableSlice& t);
// The cell of u in a cumulative table: the first i in [0, n) with cdf[i + 1] > u (cdf[0] =
// 0, cdf[n] = 1).
std::size_t cdf_find(const float* cdf, std::size_t n, double u);

// How the MIS estimators combine their techniques (docs/sampling.md, "Sampling with the
// lighting"): one-sample MIS, each technique picked with its fraction.
struct MisOptions {
  double uniform_fraction = 0.1;  // mis_tab, and the BSDF side of mis_light_gmm: uniform's share
  // make_problem sets uniform_fraction to the mixture's earned share at omega_o
  // (MixtureSet::defensive; docs/sampling.md, "The earned share")
  bool earned = false;
  double light_fraction = 0.5;    // mis_light_cdf, mis_light_gmm: light sampling's share
  double product_fraction = 0.8;  // mis_product: the product's share ...
  double product_light = 0.1;     // ... light sampling's; uniform takes the rest
  bool power = false;             // the power heuristic (beta 2) instead of the balance heuristic
  mix::ProductOptions product;    // pruning of the product's component pairs
};

struct Problem {
  const mix::MixtureSet* set = nullptr;  // the set serving omega_o (MixtureSet::serving when Displace)
  std::shared_ptr<const mix::MixtureSet> serving;  // owns it in that case
  double theta_o = 0, phi_o = 0;
  QueryMixture query;
  TableSlice table;
  CellCdf cdf;
  Lighting light;
  LightSampler light_sampler;
  // The blended BSDF mixture times the lighting mixture (when one is given), and the
  // share of the product's mass its pruned pairs keep.
  bool has_product = false;
  mix::SliceMixture product;
  QueryMixture product_query;
  double product_kept = 1;
  MisOptions mis;
  // The estimators that need it (kNeedsRgl): the RGL file the table was imported from (its
  // warps draw the light direction for the view omega_o; f stays the table's). Not owned;
  // nullptr: none.
  const RglBrdf* rgl = nullptr;
  std::vector<float> geometry() const;
};

Problem make_problem(const TableReader& table, const mix::MixtureSet& set, double theta_o, double phi_o,
                     const Lighting& light, double uniform_fraction);
// `light_mixture`: the lighting's mixture over the table's (theta, phi) frame; needed by
// product and mis_product (nullptr: those estimators are refused).
Problem make_problem(const TableReader& table, const mix::MixtureSet& set, double theta_o, double phi_o,
                     const Lighting& light, const MisOptions& mis, const mix::SliceMixture* light_mixture);

// The density per steradian with which estimator `e` draws (theta, phi) (world phi): the
// MIS estimators' combined density (balance), 0 outside the domain.
double estimator_pdf(const Problem& p, Estimator e, double theta, double phi);

// The direction (theta, phi; world phi) that estimator `e` draws from the uniforms u, as
// estimate_cpu draws it, for us_tab, us_gmm, is_tab, is_gmm, mis_tab, cdf_tab, light,
// product and is_rgl: false when it draws none (a sample outside the domain, an empty cell). Its
// density is estimator_pdf. Throws std::invalid_argument for the other MIS estimators.
bool draw_cpu(const Problem& p, Estimator e, const double u[4], double& theta, double& phi);

// The uniforms of sample n of run r: counter {n lo, n hi, stream, r}.
void run_uniforms(std::uint64_t seed, std::uint32_t stream, std::uint32_t run, std::uint64_t n, double u[4]);

// One estimate with uniforms u (double; the reference of kernels/sample.cl `estimate`).
double estimate_cpu(const Problem& p, Estimator e, const double u[4]);

// Per run, the sums of the first N estimates for N = 1, 2, 4, .., n_max (a power of two).
struct RunSums {
  int runs = 0, levels = 0;   // levels = log2(n_max) + 1
  std::vector<double> sum;    // [run][level]
  double seconds = 0;         // time spent estimating (the timed launch)
  double at(int r, int l) const { return sum[std::size_t(r) * std::size_t(levels) + std::size_t(l)]; }
};

RunSums integrate_cpu(const Problem& p, Estimator e, int runs, std::uint64_t n_max, std::uint64_t seed);
// The device's run sums, for the estimators of the kernel (on_device); the others throw
// ConfigError (the study runs them with integrate_cpu).
RunSums integrate_device(const Device& device, const Problem& p, Estimator e, int runs, std::uint64_t n_max,
                         std::uint64_t seed, std::uint32_t chunk = 256);
// Seconds of one more launch of integrate_device's shape (after its untimed warm-up),
// without reading the sums: the study's timing rounds, interleaved over the estimators.
double time_integrate_device(const Device& device, const Problem& p, Estimator e, int runs, std::uint64_t n_max,
                             std::uint64_t seed, std::uint32_t chunk = 256);

}  // namespace bsdfmix
