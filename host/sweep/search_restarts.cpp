// `search: restarts`: the Gaussian-count search by independent restarts per candidate K.
#include "core/error.hpp"
#include "sweep/batch.hpp"
#include "sweep/criterion.hpp"

namespace bsdfmix {

// Every candidate K and restart of every slice in one submission; the criterion
// picks each slice's K, and the best restart of that K is its fit so far. The final
// fits (Batch::final_fits) then fit the chosen K again, longer and from more restarts.
void search_restarts(Batch& b) {
  const FitSettings& fit = b.fit;
  std::vector<EmTask> tasks;
  for (std::size_t s = 0; s < b.size(); ++s) {
    if (b.zero(s)) continue;
    for (int k : b.ks)
      for (int r = 0; r < fit.restarts; ++r)
        tasks.push_back(make_task(s, k, fit.iterations, fit.tolerance, task_seed(fit.seed, b.work[s].ref.index, k, r)));
  }
  const std::vector<EmResult> results = b.engine.fit(fit.search_pool > 1 ? b.pooled_set() : b.full_set, tasks);
  std::size_t ti = 0;
  for (std::size_t s = 0; s < b.size(); ++s) {
    if (b.zero(s)) continue;
    std::vector<Candidate> cands;
    std::vector<Fitted> per_k;  // the best restart of each candidate
    for (int k : b.ks) {
      Candidate c{k, 1e300, false};
      Fitted kbest;
      for (int r = 0; r < fit.restarts; ++r, ++ti) {
        const Fitted f = evaluate(results[ti], b.work[s].full);
        if (f.ok && f.l1 < c.l1_rel) {
          c.ok = true;
          c.l1_rel = f.l1;
          kbest = f;
        }
        b.search_rows[s].push_back(b.search_row(s, k, r, f));
      }
      cands.push_back(c);
      per_k.push_back(kbest);
    }
    std::size_t pick = 0;
    try {
      pick = choose_candidate(cands, fit.k_penalty, fit.error_target);
    } catch (const Error&) {
      pick = 0;  // every candidate failed: the final fits try k_min
    }
    b.chosen[s] = cands[pick].k;
    b.best[s] = per_k[pick];
    b.mark_chosen(s);
  }
}

}  // namespace bsdfmix
