// One Gaussian matched to a slice's moments.
#include "fit/moment_gaussian.hpp"

#include <algorithm>
#include <cmath>

#include "core/domain.hpp"

namespace bsdfmix {

Gmm moment_gaussian(const SliceGrid& grid, const std::vector<double>& w) {
  const std::size_t n = grid.cells();
  const bool periodic = grid.map != Map::Disk;  // y is an angle, averaged on the circle
  std::vector<double> xs(n), ys(n);
  double W = 0, mt = 0, cx = 0, cy = 0;
  for (std::size_t i = 0; i < n; ++i) {
    cell_point(grid, i, xs[i], ys[i]);
    const double x = w[i];
    W += x;
    mt += x * xs[i];
    cx += x * (periodic ? std::cos(ys[i]) : ys[i]);
    cy += x * (periodic ? std::sin(ys[i]) : 0.0);
  }
  const double mp = W > 0 ? (periodic ? std::atan2(cy, cx) : cx / W) : 0.0;
  mt = W > 0 ? mt / W : (grid.map == Map::Disk ? 0.0 : 0.5 * (xs.front() + xs.back()));
  double stt = 0, stp = 0, spp = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const double x = w[i];
    const double dt = xs[i] - mt, dp = periodic ? wrap_phi(ys[i] - mp) : ys[i] - mp;
    stt += x * dt * dt;
    stp += x * dt * dp;
    spp += x * dp * dp;
  }
  const double floor = std::pow(0.25 * plane_step(grid), 2);  // EM's default floor
  if (W > 0) {
    stt /= W;
    stp /= W;
    spp /= W;
  } else {
    stt = spp = 1.0;
    stp = 0;
  }
  stt = std::max(stt, floor);
  spp = std::max(spp, floor);
  if (stt * spp - stp * stp <= 0) stp = 0;
  Gmm g;
  g.weight = {1.0};
  g.mean = {mt, wrap_phi(mp)};
  g.cov = {stt, stp, spp};
  return g;
}

}  // namespace bsdfmix
