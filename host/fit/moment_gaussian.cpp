// One Gaussian matched to a slice's moments.
#include "fit/moment_gaussian.hpp"

#include <algorithm>
#include <cmath>

#include "core/domain.hpp"

namespace bsdfmix {

Gmm moment_gaussian(const SliceGrid& grid, const std::vector<double>& w) {
  const std::vector<double>& theta = grid.theta;
  const std::vector<double>& phi = grid.phi;
  const std::size_t np = phi.size();
  double W = 0, mt = 0, cx = 0, cy = 0;
  for (std::size_t t = 0; t < theta.size(); ++t)
    for (std::size_t p = 0; p < np; ++p) {
      const double x = w[t * np + p];
      W += x;
      mt += x * theta[t];
      cx += x * std::cos(phi[p]);
      cy += x * std::sin(phi[p]);
    }
  const double mp = W > 0 ? std::atan2(cy, cx) : 0.0;
  mt = W > 0 ? mt / W : 0.5 * (theta.front() + theta.back());
  double stt = 0, stp = 0, spp = 0;
  for (std::size_t t = 0; t < theta.size(); ++t)
    for (std::size_t p = 0; p < np; ++p) {
      const double x = w[t * np + p];
      const double dt = theta[t] - mt, dp = wrap_phi(phi[p] - mp);
      stt += x * dt * dt;
      stp += x * dt * dp;
      spp += x * dp * dp;
    }
  const double floor = std::pow(0.25 * std::min(axis_step(theta), axis_step(phi)), 2);  // EM's default floor
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
