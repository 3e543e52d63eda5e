// The Gaussian-count criterion of the search.
#include "sweep/criterion.hpp"

#include <algorithm>

#include "core/error.hpp"

namespace bsdfmix {

double candidate_score(int k, double l1_rel, double k_penalty) { return l1_rel + k_penalty * k; }

std::size_t choose_candidate(const std::vector<Candidate>& c, double k_penalty, std::optional<double> target) {
  std::size_t best = c.size();
  if (target) {
    for (std::size_t i = 0; i < c.size(); ++i)
      if (c[i].ok && c[i].l1_rel <= *target) return i;
    for (std::size_t i = c.size(); i-- > 0;)
      if (c[i].ok) return i;
  } else {
    for (std::size_t i = 0; i < c.size(); ++i) {
      if (!c[i].ok) continue;
      if (best == c.size() ||
          candidate_score(c[i].k, c[i].l1_rel, k_penalty) < candidate_score(c[best].k, c[best].l1_rel, k_penalty))
        best = i;
    }
  }
  if (best == c.size()) throw Error("every candidate K failed to fit");
  return best;
}

std::vector<int> candidate_ks(int k_min, int k_max) {
  std::vector<int> ks;
  int k = 1;
  while (k <= k_max) {
    if (k >= k_min) ks.push_back(k);
    const int step = k < 8 ? 1 : k < 12 ? 2 : k < 24 ? 4 : k < 48 ? 8 : 16;
    k += step;
  }
  if (ks.empty() || ks.front() != k_min) ks.insert(ks.begin(), k_min);
  if (ks.back() != k_max) ks.push_back(k_max);
  return ks;
}

}  // namespace bsdfmix
