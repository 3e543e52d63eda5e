// One batch of slices as the sweep fits it: the state its search strategy and its final
// fits share (inside host/sweep/ only). The batch fitter (sweep/batch_fitter.cpp) loads
// a batch, runs the strategy of `fit.search` on it, reduces K where a slice has too few
// non-zero cells, and makes its part; the strategies live in search_restarts.cpp and
// search_smem.cpp.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "sweep/fit_settings.hpp"
#include "fit/em.hpp"
#include "sweep/base_lobe.hpp"
#include "sweep/fit_error.hpp"
#include "sweep/fit_phases.hpp"
#include "sweep/fit_slices.hpp"
#include "sweep/slice_plan.hpp"

namespace bsdfmix {

// The seed of one (slice, K, restart) problem: independent of batching and devices.
std::uint64_t task_seed(std::uint64_t seed, std::size_t slice, int k, int restart);

// One EM problem: slice `slice` of the set, K components, one restart.
EmTask make_task(std::size_t slice, int k, int iterations, double tolerance, std::uint64_t seed);

// One fit of a slice, with its relative L1 error at full resolution.
struct Fitted {
  bool ok = false;
  std::string failure;  // why, when !ok
  Gmm gmm;
  double loglik = 0, l1 = 0;
  int iterations = 0;
};

// An EM result judged against the slice at full resolution.
Fitted evaluate(const EmResult& r, const WeightedSlice& full);

struct SliceWork {
  SliceRef ref;
  WeightedSlice full, pooled;  // pooled: the search's coarser slice (search_pool)
  std::vector<double> rgb;     // with colour: the R, G, B integrand weights (SliceSource::rgb_weights)
  double total = 0;
  // On the disk: the Lambertian base taken off `full` and `rgb` (sweep/base_lobe.hpp), and
  // the slice as the table has it (`table`, `table_rgb`), which the stand-in is judged on.
  SliceBase base;
  WeightedSlice table;
  std::vector<double> table_rgb;
};

struct Batch {
  Batch(const FitSettings& fit, EmEngine& engine, Domain domain);

  const FitSettings& fit;
  EmEngine& engine;
  const Domain domain;
  const std::vector<int> ks;  // the candidate Ks (sweep/criterion.hpp)
  std::vector<SliceWork> work;
  SliceSet full_set;  // every slice of the batch at full resolution
  // Per slice: the K chosen, the K it was reduced from (0: not), the fit kept so far,
  // with `search: smem` the search's fits of the candidate Ks below and above the chosen
  // one, the first failure seen, and its rows of the search CSV in the order searched.
  std::vector<int> chosen, reduced_from;
  std::vector<Fitted> best, below, above;
  // With `search: smem`, a walk that stalled with a poor best fit (search_smem.cpp): the
  // K it is fitted at past its last one, from k-means++ restarts (0: none), and that fit.
  std::vector<int> beyond_k;
  std::vector<Fitted> beyond;
  std::vector<std::string> failure;
  std::vector<std::vector<SearchRow>> search_rows;
  FitPhases phases;  // the wall seconds of its phases so far

  std::size_t size() const { return work.size(); }
  bool zero(std::size_t s) const { return !(work[s].total > 0); }
  // The slices as the search fits them: pooled by search_pool, or the full set.
  SliceSet pooled_set() const;
  // A search CSV row of slice s for a fit of K (`chosen` still false).
  SearchRow search_row(std::size_t s, int k, int restart, const Fitted& f) const;
  // Sets `chosen` on the search rows of slice s: those of its chosen K.
  void mark_chosen(std::size_t s);

  // Keeps `f` as the slice's fit when it is usable and has a lower L1 error.
  void offer(std::size_t s, const Fitted& f);
  // Fits `tasks` on the full set and offers every result.
  void run(const std::vector<EmTask>& tasks);
  // The chosen K of every slice at full resolution, with final_restarts and final_iterations.
  void final_fits();
  // The L1 refinement of every kept fit and, with `with_neighbours`, of every fit below
  // and above it and beyond a stalled walk.
  void refine(bool with_neighbours);
  void refine_queries(const EmEngine::L1Slices& slices, const std::vector<L1Query>& queries,
                      const std::vector<Fitted*>& owners);
  // A slice with fewer non-zero cells than K is refitted with one component per cell.
  void reduce_k();
};

// `search: restarts` (search_restarts.cpp): every candidate K from independent restarts.
void search_restarts(Batch& b);

// `search: smem` (search_smem.cpp): the walk over K with split-and-merge moves, and its
// final fits (which start from the walk's fits and reconsider the K below the chosen one).
void search_smem(Batch& b);
void final_smem(Batch& b);

}  // namespace bsdfmix
