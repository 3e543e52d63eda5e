// The study's estimator names as the config parser checks them (the registry of
// sampling/estimator.hpp).
#pragma once

#include <string>

#include "sampling/estimator.hpp"

namespace bsdfmix {

inline bool known_estimator(const std::string& name) {
  const EstimatorInfo* e = find_estimator(name);
  return e != nullptr && e->in_study();
}

}  // namespace bsdfmix
