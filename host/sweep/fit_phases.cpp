// The phases of a fit, summed and printed (sweep/fit_phases.hpp).
#include "sweep/fit_phases.hpp"

#include <cstdio>
#include <utility>

namespace bsdfmix {

FitPhases& FitPhases::operator+=(const FitPhases& o) {
  search += o.search;
  final_em += o.final_em;
  beyond += o.beyond;
  refine += o.refine;
  rest += o.rest;
  return *this;
}

std::string FitPhases::text() const {
  const double t = total();
  if (!(t > 0)) return "";
  const std::pair<const char*, double> parts[] = {{"search", search},          {"final EM", final_em},
                                                   {"past a stalled walk", beyond}, {"L1 refinement", refine},
                                                   {"the rest", rest}};
  std::string s;
  char buf[64];
  for (const auto& [name, seconds] : parts) {
    std::snprintf(buf, sizeof buf, "%s%s %.0f%%", s.empty() ? "" : ", ", name, 100.0 * seconds / t);
    s += buf;
  }
  std::snprintf(buf, sizeof buf, " of %.1f s in batches", t);
  return s + buf;
}

}  // namespace bsdfmix
