// The Gaussian-count criterion of the search (docs/fitting.md).
//
// Each candidate K of a slice is fitted (several restarts, best kept) and scored by
//   score(K) = l1_rel(K) + k_penalty * K
// where l1_rel is the relative L1 error of the mixture as a stand-in for the slice
// (the share of the slice's integral that the mixture misplaces). A component earns its
// place only when it removes more than k_penalty of the error (default 0.004: 0.4% of
// the slice's energy). The chosen K minimizes the score. With an error target, the
// chosen K is the smallest whose l1_rel meets the target (the largest candidate when
// none does).
#pragma once

#include <optional>
#include <vector>

namespace bsdfmix {

struct Candidate {
  int k = 0;
  double l1_rel = 0;  // best over restarts
  bool ok = false;    // false: every restart failed
};

double candidate_score(int k, double l1_rel, double k_penalty);

// Index into `candidates` (sorted by k) of the chosen K. Throws Error when none is ok.
std::size_t choose_candidate(const std::vector<Candidate>& candidates, double k_penalty,
                             std::optional<double> error_target);

// The K values searched between k_min and k_max: every K up to 8, then steps that grow
// with K (10, 12, 16, 20, 24, 32, 40, 48, 64, ...), always including k_min and k_max.
std::vector<int> candidate_ks(int k_min, int k_max);

}  // namespace bsdfmix
