// Slices whose weights are known mixtures.
#include "fit/synthetic.hpp"

#include <cmath>

namespace bsdfmix {

std::vector<double> mixture_weights(const SliceGrid& grid, const Gmm& gmm) {
  std::vector<double> w(grid.cells());
  for (std::size_t i = 0; i < w.size(); ++i) {
    double x, y;
    cell_point(grid, i, x, y);
    w[i] = gmm_density(gmm, x, y) * cell_jacobian(grid, i);
  }
  return w;
}

Gmm synthetic_lobes(Domain domain, int lobes, std::uint64_t seed) {
  std::uint64_t s = seed * 0x9E3779B97F4A7C15ULL + 0x632BE59BD9B4E019ULL;
  auto uniform = [&s] {
    s ^= s << 13;
    s ^= s >> 7;
    s ^= s << 17;
    return static_cast<double>(s >> 11) * 0x1.0p-53;
  };
  const double lo = theta_lo(domain), hi = theta_hi(domain);
  const double span = hi - lo;
  Gmm g;
  double wsum = 0;
  for (int j = 0; j < lobes; ++j) {
    const double wj = j == 0 ? 0.4 : 0.2 + 0.4 * uniform();
    const double mt = lo + span * (0.25 + 0.5 * uniform());
    double mp;
    if (j == 0) mp = 0.1;
    else if (j == 1) mp = kPi - 0.05;  // straddles phi = +-pi
    else mp = -kPi + 2 * kPi * uniform();
    const double st = (j == 0 ? 0.04 : 0.06 + 0.1 * uniform()) * span;
    const double sp = j == 0 ? 0.08 : 0.15 + 0.35 * uniform();
    const double rho = -0.5 + uniform();
    g.weight.push_back(wj);
    wsum += wj;
    g.mean.push_back(mt);
    g.mean.push_back(wrap_phi(mp));
    g.cov.push_back(st * st);
    g.cov.push_back(rho * st * sp);
    g.cov.push_back(sp * sp);
  }
  for (double& w : g.weight) w /= wsum;
  return g;
}

}  // namespace bsdfmix
