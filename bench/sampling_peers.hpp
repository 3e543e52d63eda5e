// `bsdfmix bench sampling` (docs/sampling.md, "Against the file's own sampler"): how well
// each way of sampling an RGL material estimates the integral of f cos(theta_i) over the
// hemisphere under constant light, f always the file's own evaluation (host/tables/
// rgl_brdf.hpp), at random view elevations. The samplers: the fitted mixture alone and
// with its defensive uniform share (is_tab's and mis_tab's draws), the file's own warps,
// the table's piecewise-constant CDF (cdf_tab's draw) and uniform directions (us_tab's).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "sampling/sampling.hpp"

namespace bsdfmix {
class RglBrdf;
}

namespace bsdfmix::bench {

struct SamplingPeersOptions {
  std::string rgl, mixture, table, csv;
  int directions = 20;
  std::uint64_t samples = 65536;
  std::uint64_t seed = 1;
  double theta_max_deg = 85;    // view elevations drawn uniformly in [0, this]
  int quadrature = 2048;        // the exact integral: cells in sin^2(theta) (twice as many in phi)
  double uniform_fraction = 0.1;  // the defensive mixture's uniform share (mis_tab's)
};

enum class Peer { IsMixture = 0, MisMixture = 1, Rgl = 2, CdfTable = 3, Uniform = 4 };
constexpr int kPeers = 5;
const char* peer_name(Peer p);

// The statistics of the weights w = f cos / pdf of n samples, against the integral I.
struct WeightStats {
  std::uint64_t n = 0;
  double mean = 0, m2 = 0, max = 0;  // running mean and sum of squared deviations (Welford)
  void add(double w);
  double variance() const { return n > 1 ? m2 / double(n - 1) : 0.0; }  // per sample
  double relvar(double integral) const { return variance() / (integral * integral); }
};

// f cos(theta_i) over the hemisphere for the view theta_o (phi_o = 0), luminance: the
// midpoint rule in (sin^2 theta, phi) on n x 2n cells.
double rgl_integral(const RglBrdf& brdf, double theta_o, int n);

// The weight of sample `index` of peer `peer` at the view of `problem` (phi_o = 0; the
// mixture and the table of the problem serve the mixture and table peers), f the file's
// luminance; run `run` of the peer's counter stream.
double peer_weight(const RglBrdf& brdf, const Problem& problem, Peer peer, std::uint64_t seed, std::uint32_t run,
                   std::uint64_t index);

// n samples of a peer.
WeightStats peer_stats(const RglBrdf& brdf, const Problem& problem, Peer peer, std::uint64_t seed,
                       std::uint32_t run, std::uint64_t n);

// The view elevations studied: `count` uniform in [0, theta_max] (radians) from `seed`.
std::vector<double> study_directions(int count, double theta_max, std::uint64_t seed);

// Runs the study on one material and writes o.csv; prints a summary unless quiet.
void bench_sampling(const SamplingPeersOptions& o, bool quiet);

}  // namespace bsdfmix::bench
