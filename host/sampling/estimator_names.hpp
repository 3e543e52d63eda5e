// The estimators' names, in the order of the Estimator enum (sampling/sampling.hpp):
// header-only, so that the config parser checks names without the sampling library.
#pragma once

#include <string>

namespace bsdfmix {

inline constexpr const char* kEstimatorNames[] = {"us_tab",        "us_gmm",        "is_tab",  "is_gmm",
                                                  "mis_tab",       "cdf_tab",       "light",   "mis_light_cdf",
                                                  "mis_light_gmm", "product",       "mis_product",   "is_rgl",
                                                  "mis_light_rgl"};
inline constexpr int kEstimatorCount = int(sizeof kEstimatorNames / sizeof kEstimatorNames[0]);

// "us_tab, us_gmm, .. or mis_light_rgl"
inline std::string estimator_list() {
  std::string s;
  for (int i = 0; i < kEstimatorCount; ++i)
    s += std::string(i ? (i + 1 == kEstimatorCount ? " or " : ", ") : "") + kEstimatorNames[i];
  return s;
}

inline bool known_estimator(const std::string& name) {
  for (const char* n : kEstimatorNames)
    if (name == n) return true;
  return false;
}

}  // namespace bsdfmix
