// The fallback fit of a slice: one Gaussian matched to its weighted moments.
#pragma once

#include <vector>

#include "fit/gmm.hpp"
#include "fit/slices.hpp"

namespace bsdfmix {

// One Gaussian with the mean and covariance of the weights `w` (row-major [theta][phi])
// on `grid`: phi's mean is circular, its spread measured wrapped around it; each
// variance at least EM's default covariance floor, the correlation dropped when the
// covariance would not be positive definite. An all-zero slice gets the grid's center
// in theta, phi 0 and unit variances. What a sweep stores where EM fails.
Gmm moment_gaussian(const SliceGrid& grid, const std::vector<double>& w);

}  // namespace bsdfmix
