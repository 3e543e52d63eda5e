// CPU references of kernels/sample.cl in double: sampling through the renderer-facing
// header (include/bsdfmix/mixture.hpp), and the convergence study's estimators run by
// their strategies (sampling/estimator.hpp; those that draw with the RGL file's own warps,
// and registered estimators, exist on the CPU alone).
#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>
#include <string>

#include "sampling/draws.hpp"
#include "sampling/sampling.hpp"

namespace bsdfmix {

std::vector<mix::Sample> sample_cpu(const mix::MixtureSet& set, double theta_o, double phi_o, std::uint64_t seed,
                                    std::uint32_t stream, std::uint64_t first, std::size_t n) {
  std::vector<mix::Sample> out(n);
  for (std::size_t i = 0; i < n; ++i) out[i] = set.sample_counter(theta_o, phi_o, seed, stream, first + i);
  return out;
}

std::size_t cdf_find(const float* cdf, std::size_t n, double u) {
  std::size_t lo = 0, hi = n;
  while (lo < hi) {
    const std::size_t mid = (lo + hi) / 2;
    if (double(cdf[mid + 1]) > u) hi = mid;
    else lo = mid + 1;
  }
  return std::min(lo, n - 1);
}

void run_uniforms(std::uint64_t seed, std::uint32_t stream, std::uint32_t run, std::uint64_t n, double u[4]) {
  const std::uint32_t ctr[4] = {std::uint32_t(n), std::uint32_t(n >> 32), stream, run};
  const std::uint32_t key[2] = {std::uint32_t(seed), std::uint32_t(seed >> 32)};
  const mix::PhiloxBlock r = mix::philox4x32_10(ctr, key);
  for (int i = 0; i < 4; ++i) u[i] = mix::to_uniform(r.v[i]);
}

double estimator_pdf(const Problem& p, Estimator e, double th, double ph) {
  if (!draws::inside(p.table.domain, th)) return 0;
  const EstimatorInfo& info = estimator_info(e);
  if (!info.study.pdf) throw std::invalid_argument(std::string("estimator_pdf: ") + info.name + " is not in the study");
  return info.study.pdf(p, th, ph);
}

bool draw_cpu(const Problem& p, Estimator e, const double u[4], double& th, double& ph) {
  const EstimatorInfo& info = estimator_info(e);
  if (!info.study.draw) throw std::invalid_argument(std::string("draw_cpu: not for ") + info.name);
  return info.study.draw(p, u, th, ph);
}

double estimate_cpu(const Problem& p, Estimator e, const double u[4]) {
  const EstimatorInfo& info = estimator_info(e);
  if (!info.study.estimate) throw std::invalid_argument(std::string("estimate_cpu: ") + info.name + " is not in the study");
  return info.study.estimate(p, u);
}

RunSums integrate_cpu(const Problem& p, Estimator e, int runs, std::uint64_t n_max, std::uint64_t seed) {
  RunSums rs;
  rs.runs = runs;
  rs.levels = 1;
  while ((std::uint64_t(1) << (rs.levels - 1)) < n_max) ++rs.levels;
  rs.sum.assign(std::size_t(runs) * std::size_t(rs.levels), 0.0);
  const std::uint32_t stream = estimator_stream(int(e));
  const EstimatorInfo& info = estimator_info(e);
  if (!info.study.estimate) throw std::invalid_argument(std::string("integrate_cpu: ") + info.name + " is not in the study");
  for (int r = 0; r < runs; ++r) {
    double s = 0;
    int level = 0;
    std::uint64_t next = 1;
    for (std::uint64_t n = 0; n < n_max; ++n) {
      double u[4];
      run_uniforms(seed, stream, std::uint32_t(r), n, u);
      s += info.study.estimate(p, u);
      if (n + 1 == next) {
        rs.sum[std::size_t(r) * std::size_t(rs.levels) + std::size_t(level++)] = s;
        next <<= 1;
      }
    }
  }
  return rs;
}

}  // namespace bsdfmix
