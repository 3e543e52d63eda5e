// `bsdfmix bench sampling` (docs/sampling.md, "Against the file's own sampler"): how well
// each way of sampling a material estimates the integral of L_i f cos(theta_i) over its
// domain, at random view elevations, under constant light and under scenes
// (configs/scenes/*.yaml). With an RGL file, f is always the file's own evaluation
// (host/tables/rgl_brdf.hpp) and its warps are a sampler; without one (a fiber table), f
// is the table. The samplers: the fitted mixture alone and with its defensive uniform
// share (is_tab's and mis_tab's draws), the file's own warps (is_rgl), the table's
// piecewise-constant CDF (cdf_tab's draw) and uniform directions (us_tab's); under a
// scene also light sampling and the one-sample MIS of light sampling with the file's
// warps (mis_light_rgl), with the table CDF (mis_light_cdf) and with the mixture
// (mis_light_gmm), and the product of the mixture with the lighting's mixture, alone
// (product) and in MIS (mis_product), as the convergence study draws them.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "fit/em.hpp"
#include "sampling/sampling.hpp"

namespace bsdfmix {
class RglBrdf;
}

namespace bsdfmix::bench {

struct SamplingPeersOptions {
  std::string rgl;  // "": f is the table (fiber presets), no RGL samplers
  std::string mixture, table, csv;
  std::vector<std::string> scenes;  // scene files studied besides constant light
  std::string light_cache;          // the lighting mixtures' cache ("": <csv dir>/light_mixtures)
  EngineOptions light_engine;       // how the engine of the lighting fits runs
  int directions = 20;
  std::uint64_t samples = 65536;
  std::uint64_t seed = 1;
  double theta_max_deg = 85;      // view elevations drawn uniformly in [0, this]
  int quadrature = 2048;          // the RGL integral: cells in sin^2(theta) (twice as many in phi)
  double uniform_fraction = 0.1;  // the defensive mixture's uniform share (mis_tab's) ...
  bool earned = true;             // ... unless each view takes the mixture's earned share (MixtureSet::defensive)
  double light_fraction = 0.5;    // light sampling's share in mis_light_rgl, mis_light_cdf, mis_light_gmm
};

// The CSV's sampler names: the constant-light samplers first (their names predate the
// scenes), then the estimators that need a scene.
enum class Peer {
  IsMixture = 0, MisMixture = 1, Rgl = 2, CdfTable = 3, Uniform = 4,
  Light = 5, MisLightRgl = 6, MisLightCdf = 7, MisLightGmm = 8, Product = 9, MisProduct = 10
};
constexpr int kPeers = 11;
const char* peer_name(Peer p);
bool peer_needs_rgl(Peer p);    // is_rgl (`rgl`), mis_light_rgl
bool peer_needs_scene(Peer p);  // light, the MIS estimators with light sampling, the product
// Whether the study has a row for the peer: with an RGL file or not, under a scene or constant light.
bool peer_studied(Peer p, bool rgl, bool scene);

// The statistics of the weights w = L f cos / pdf of n samples, against the integral I.
struct WeightStats {
  std::uint64_t n = 0;
  double mean = 0, m2 = 0, max = 0;  // running mean and sum of squared deviations (Welford)
  void add(double w);
  double variance() const { return n > 1 ? m2 / double(n - 1) : 0.0; }  // per sample
  double relvar(double integral) const { return variance() / (integral * integral); }
};

// L_i f cos(theta_i) over the hemisphere for the view theta_o (phi_o = 0), f the file's
// luminance, one integral per lighting (in the table's frame): the midpoint rule in
// (sin^2 theta, phi) on n x 2n cells, f evaluated once per node for all of them.
std::vector<double> rgl_integrals(const RglBrdf& brdf, double theta_o, const std::vector<const Lighting*>& lights,
                                  int n);
// The same under constant light 1.
double rgl_integral(const RglBrdf& brdf, double theta_o, int n);

// The weight L f cos / pdf of sample `index` of peer `peer` at the view of `problem`
// (phi_o = 0; the mixture, the table and the lighting of the problem serve the mixture,
// table and light peers), f the file's luminance (brdf) or the table (brdf == nullptr);
// run `run` of the peer's counter stream.
double peer_weight(const RglBrdf* brdf, const Problem& problem, Peer peer, std::uint64_t seed, std::uint32_t run,
                   std::uint64_t index);

// n samples of a peer.
WeightStats peer_stats(const RglBrdf* brdf, const Problem& problem, Peer peer, std::uint64_t seed,
                       std::uint32_t run, std::uint64_t n);

// The view elevations studied: `count` uniform in [0, theta_max] (radians) from `seed`.
std::vector<double> study_directions(int count, double theta_max, std::uint64_t seed);

// Runs the study on one material and writes o.csv; prints a summary unless quiet.
// `device`: the selector of the device that fits the lighting mixtures (the product's).
void bench_sampling(const SamplingPeersOptions& o, const std::string& device, bool quiet);

}  // namespace bsdfmix::bench
