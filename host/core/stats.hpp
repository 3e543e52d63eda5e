// The one quantile and the one percent rounding that every summary uses (fit, compare,
// inspect, catalog): docs/formats.md, "Medians and percentiles".
#pragma once

#include <string>
#include <vector>

namespace bsdfmix {

// The q-quantile (q in [0, 1]) of `v`, interpolated linearly between the two nearest
// order statistics (numpy's default): the median of an even count is the mean of the
// two middle values; q = 1 is the largest. 0 for an empty `v`.
double quantile(std::vector<double> v, double q);

// A fraction as a percentage with two decimals: 0.04523 -> "4.52%".
std::string percent_text(double fraction);

}  // namespace bsdfmix
