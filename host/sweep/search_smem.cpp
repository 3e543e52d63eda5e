// `search: smem`: the walk over K with split-and-merge moves, and its final fits.
#include <algorithm>
#include <thread>

#include "core/error.hpp"
#include "fit/em_internal.hpp"
#include "fit/scheduler.hpp"
#include "fit/smem.hpp"
#include "sweep/batch.hpp"
#include "sweep/criterion.hpp"

namespace bsdfmix {

namespace {

// Candidates a slice walks past its best score before it stops (a heuristic).
constexpr int kWalkPatience = 2;
// A stalled walk whose best fit still misplaces this share of the slice gets a fit past
// its last K (final_smem); below it, such fits were measured to lose to the walk's.
constexpr double kRescueL1 = 0.10;

std::size_t host_threads() { return std::max(1u, std::thread::hardware_concurrency()); }

EmFitter engine_fitter(EmEngine& engine) {
  return [&engine](const SliceSet& ss, const std::vector<EmTask>& t) { return engine.fit(ss, t); };
}


// One slice's walk over the candidate Ks.
struct Walk {
  bool active = false;
  EmResult cur;  // the fit of the last K walked
  std::vector<Candidate> cands;
  std::vector<Fitted> per_k;
  double best_score = 1e300;
  Gmm best_gmm;        // the fit of the best score so far
  int since_best = 0;  // candidates walked since the best score last improved
  int tried_well = 0;  // of those, the ones started twice from the best fit
  bool gave_up = false;  // stopped by the patience with larger Ks left
};

// One step of the walk: the tasks of candidate ks[ki] for the slices still walking
// (`live`), grown on the host in parallel. A stalled slice (its last K did not improve
// the best score) gets two starts: starts[i] of them from task first[i] on.
std::vector<EmTask> walk_tasks(const Batch& b, const SliceSet& set, const std::vector<Walk>& walk,
                               const std::vector<std::size_t>& live, std::size_t ki, std::vector<int>& starts,
                               std::vector<std::size_t>& first) {
  const FitSettings& fit = b.fit;
  const int k = b.ks[ki];
  starts.assign(live.size(), 1);
  first.assign(live.size(), 0);
  std::size_t n_tasks = 0;
  for (std::size_t i = 0; i < live.size(); ++i) {
    const Walk& wk = walk[live[i]];
    starts[i] = ki > 0 && wk.since_best > 0 && wk.best_gmm.k() > 0 && wk.best_gmm.k() < k ? 2 : 1;
    first[i] = n_tasks;
    n_tasks += std::size_t(starts[i]);
  }
  std::vector<EmTask> tasks(n_tasks);
  run_on_workers(live.size(), std::min(host_threads(), live.size()), [&](std::size_t, std::size_t i) {
    const std::size_t s = live[i];
    const Walk& wk = walk[s];
    for (int r = 0; r < starts[i]; ++r) {
      EmTask t = make_task(s, k, fit.iterations, fit.tolerance, task_seed(fit.seed, b.work[s].ref.index, k, r));
      const double floor = em_detail::cov_floor(set.grid, t.settings);
      // start 0 grows the last fit by splits; start 1 seeds the best fit at the residual
      const bool from_last = r == 0;
      const Gmm& from = from_last ? wk.cur.gmm : wk.best_gmm;
      if (ki > 0 && (!from_last || wk.cur.ok) && from.k() < k) {
        if (r == 0) {
          t.init = grow_mixture(from, score_components(set.grid, set.weights[s], from, 0), k, floor);
        } else {
          t.init = seed_at_residual(set.grid, set.weights[s], from, k, floor);
          if (t.init.k() < k) t.init = grow_mixture(t.init, score_components(set.grid, set.weights[s], t.init, 0), k, floor);
        }
      } else {
        t.settings.restarts = fit.restarts;  // no fit to grow: k-means++ restarts
      }
      tasks[first[i] + std::size_t(r)] = std::move(t);
    }
  });
  return tasks;
}

// Slice s's walk after candidate ks[ki]: its better start (of `starts` from task
// `first`) kept, its search rows, and whether it walks on.
void advance_walk(Batch& b, Walk& wk, std::size_t s, std::size_t ki, const std::vector<EmResult>& res,
                  const std::vector<Fitted>& fitted, int starts, std::size_t first) {
  const FitSettings& fit = b.fit;
  const std::vector<int>& ks = b.ks;
  const int k = ks[ki];
  std::size_t pick = first;
  for (int r = 1; r < starts; ++r) {
    const Fitted& g = fitted[first + std::size_t(r)];
    if (g.ok && (!fitted[pick].ok || g.l1 < fitted[pick].l1)) pick = first + std::size_t(r);
  }
  wk.cur = res[pick];
  const Fitted& f = fitted[pick];
  wk.cands.push_back(Candidate{k, f.ok ? f.l1 : 1e300, f.ok});
  wk.per_k.push_back(f);
  if (f.ok && candidate_score(k, f.l1, fit.k_penalty) < wk.best_score) {
    wk.best_score = candidate_score(k, f.l1, fit.k_penalty);
    wk.best_gmm = f.gmm;
    wk.since_best = wk.tried_well = 0;
  } else {
    ++wk.since_best;
    wk.tried_well += starts == 2;
  }
  if (!fit.error_target && wk.since_best >= kWalkPatience && wk.tried_well > 0) {
    wk.active = false;
    wk.gave_up = ki + 1 < ks.size();
  }
  for (int r = 0; r < starts; ++r) b.search_rows[s].push_back(b.search_row(s, k, r, fitted[first + std::size_t(r)]));
  if (fit.error_target ? f.ok && f.l1 <= *fit.error_target
                       : ki + 1 < ks.size() && wk.best_score <= fit.k_penalty * ks[ki + 1])
    wk.active = false;
}

// Slice s's choice after its walk: the chosen K, its fit and its neighbours' fits, and
// the K past a stalled walk (beyond_k).
void end_walk(Batch& b, const Walk& wk, std::size_t s) {
  const FitSettings& fit = b.fit;
  const std::vector<int>& ks = b.ks;
  std::size_t pick = 0;
  try {
    pick = choose_candidate(wk.cands, fit.k_penalty, fit.error_target);
  } catch (const Error&) {
    pick = 0;  // every candidate failed: the final fits try k_min
  }
  b.chosen[s] = wk.cands[pick].k;
  b.best[s] = wk.per_k[pick];
  if (pick > 0 && wk.per_k[pick - 1].ok) b.below[s] = wk.per_k[pick - 1];
  if (pick + 1 < wk.per_k.size() && wk.per_k[pick + 1].ok) b.above[s] = wk.per_k[pick + 1];
  // Stalled: the patience ended a walk in which a K past the best one had a larger L1
  // error (EM's fits getting worse with K: a local optimum the grown starts could not
  // leave, not a plateau of the score). When its best fit is still poor, its final fits
  // weigh one more K, two steps past the last walked, fitted from scratch.
  if (wk.gave_up && wk.cands[pick].ok && wk.cands[pick].l1_rel >= kRescueL1) {
    const double l1 = wk.cands[pick].l1_rel;
    const bool worse = std::any_of(wk.cands.begin() + long(pick) + 1, wk.cands.end(),
                                   [l1](const Candidate& c) { return c.ok && c.l1_rel > l1; });
    // gave_up: the last K walked is not the last of ks
    const auto last = std::find(ks.begin(), ks.end(), wk.cands.back().k);
    if (worse) b.beyond_k[s] = ks.end() - last > 2 ? last[2] : last[1];
  }
}

}  // namespace

// The walk over K (docs/studies/search.md, "The walk, step by step"). Every slice of the
// batch walks the candidate Ks upwards together: the first K starts from k-means++
// restarts, each later K from the previous K's fit grown by splitting its worst-fitting
// components; after EM, split-and-merge rounds move components out of local optima. Each step is a batched
// engine call over the slices still walking. A slice stops walking once no larger K can
// win: its best score is at most k_penalty times the next K (l1_rel >= 0), or, with an
// error target, once a K meets it; and (a heuristic) when its best score has not
// improved over the last kWalkPatience candidates, one of them at least tried well.
// Once a K has not improved the best score, the walk may be in a local optimum: each
// later K starts twice, from the last fit grown by splitting (as before) and from the
// best fit so far grown by components seeded at the slice's largest residual (a sharp
// peak the splits miss), and keeps the better: that K was tried well.
void search_smem(Batch& b) {
  const FitSettings& fit = b.fit;
  const bool pooled = fit.search_pool > 1;
  const SliceSet pooled_set = pooled ? b.pooled_set() : SliceSet{};
  const SliceSet& set = pooled ? pooled_set : b.full_set;
  const std::size_t n = b.size();
  const EmFitter fitter = engine_fitter(b.engine);
  const SmemSettings smem;
  std::vector<Walk> walk(n);
  for (std::size_t s = 0; s < n; ++s) walk[s].active = !b.zero(s);
  for (std::size_t ki = 0; ki < b.ks.size(); ++ki) {
    std::vector<std::size_t> live;
    for (std::size_t s = 0; s < n; ++s)
      if (walk[s].active) live.push_back(s);
    if (live.empty()) break;
    std::vector<int> starts;
    std::vector<std::size_t> first;
    const std::vector<EmTask> tasks = walk_tasks(b, set, walk, live, ki, starts, first);
    const std::vector<EmResult> res = split_merge_fit(fitter, set, tasks, smem);
    std::vector<Fitted> fitted(tasks.size());
    run_on_workers(tasks.size(), std::min(host_threads(), tasks.size()),
                   [&](std::size_t, std::size_t i) { fitted[i] = evaluate(res[i], b.work[tasks[i].slice].full); });
    for (std::size_t i = 0; i < live.size(); ++i)
      advance_walk(b, walk[live[i]], live[i], ki, res, fitted, starts[i], first[i]);
  }
  for (std::size_t s = 0; s < n; ++s)
    if (!walk[s].cands.empty()) end_walk(b, walk[s], s);
}

namespace {

// The final fits' tasks of every slice: restarts of the chosen K (restart 0 from the
// search's fit; with K pinned, into `first`, for split-and-merge rounds), and the K below
// and above it from their search fits (role: 0 the chosen K, 1 the K below, 2 the K above).
void final_tasks(const Batch& b, std::vector<EmTask>& tasks, std::vector<EmTask>& first, std::vector<int>& role) {
  const FitSettings& fit = b.fit;
  const std::size_t n = b.size();
  for (std::size_t s = 0; s < n; ++s) {
    if (b.zero(s)) continue;
    for (int r = 0; r < fit.final_restarts; ++r) {
      EmTask t = make_task(s, b.chosen[s], fit.final_iterations, fit.tolerance,
                           task_seed(fit.seed, b.work[s].ref.index, b.chosen[s], -1 - r));
      if (r == 0 && b.best[s].ok && b.best[s].gmm.k() == b.chosen[s]) t.init = b.best[s].gmm;
      if (r == 0 && fit.k_min == fit.k_max) {
        first.push_back(std::move(t));
        continue;
      }
      tasks.push_back(std::move(t));
      role.push_back(0);
    }
    if (b.below[s].ok) {
      EmTask t = make_task(s, b.below[s].gmm.k(), fit.final_iterations, fit.tolerance,
                           task_seed(fit.seed, b.work[s].ref.index, b.below[s].gmm.k(), -1));
      t.init = b.below[s].gmm;
      tasks.push_back(t);
      role.push_back(1);
      // And the chosen fit with its two most overlapping components merged (a lobe
      // the search split in two while it had not yet separated two others).
      if (b.best[s].ok && b.best[s].gmm.k() == b.below[s].gmm.k() + 1) {
        const ComponentScores sc = score_components(b.full_set.grid, b.full_set.weights[s], b.best[s].gmm, 1);
        if (!sc.merge.empty()) {
          t.init = merge_components(b.best[s].gmm, sc.merge[0].first, sc.merge[0].second);
          tasks.push_back(std::move(t));
          role.push_back(1);
        }
      }
    }
    if (b.above[s].ok) {  // from its search fit, and from one k-means++ restart
      for (int r = 0; r < 2; ++r) {
        EmTask t = make_task(s, b.above[s].gmm.k(), fit.final_iterations, fit.tolerance,
                             task_seed(fit.seed, b.work[s].ref.index, b.above[s].gmm.k(), -1 - r));
        if (r == 0) t.init = b.above[s].gmm;
        tasks.push_back(std::move(t));
        role.push_back(2);
      }
    }
  }
}

// Beyond a stalled walk: the K past it from twice the final restarts of k-means++, each
// followed by split-and-merge rounds (the few slices this takes are the poorest).
void fit_beyond(Batch& b) {
  const FitSettings& fit = b.fit;
  const std::size_t n = b.size();
  std::vector<EmTask> rescue;
  for (std::size_t s = 0; s < n; ++s)
    for (int r = 0; b.beyond_k[s] > 0 && !b.zero(s) && r < 2 * fit.final_restarts; ++r)
      rescue.push_back(make_task(s, b.beyond_k[s], fit.final_iterations, fit.tolerance,
                                 task_seed(fit.seed, b.work[s].ref.index, b.beyond_k[s], -1 - r)));
  if (!rescue.empty()) {
    std::vector<EmResult> res = split_merge_fit(engine_fitter(b.engine), b.full_set, rescue, SmemSettings{});
    // And the same starts without the split-and-merge round, whose moves are kept by the
    // log-likelihood: on a grazing slice it moves a component onto the sharpest row of
    // cells, where the likelihood gains and the L1 error loses.
    const std::vector<EmResult> plain = b.engine.fit(b.full_set, rescue);
    res.insert(res.end(), plain.begin(), plain.end());
    std::vector<Fitted> fitted(res.size());
    run_on_workers(res.size(), std::min(res.size(), host_threads()), [&](std::size_t, std::size_t i) {
      fitted[i] = evaluate(res[i], b.work[rescue[i % rescue.size()].slice].full);
    });
    for (std::size_t i = 0; i < res.size(); ++i) {
      const std::size_t s = rescue[i % rescue.size()].slice;
      const Fitted& f = fitted[i];
      if (f.ok && (!b.beyond[s].ok || f.l1 < b.beyond[s].l1)) b.beyond[s] = f;
    }
    for (std::size_t s = 0; s < n; ++s)  // one search row per slice: the best of its restarts
      if (b.beyond_k[s] > 0 && !b.zero(s)) b.search_rows[s].push_back(b.search_row(s, b.beyond_k[s], 2, b.beyond[s]));
  }
}

// Slice s's final choice among the chosen K, the K below and above, and the K beyond a
// stalled walk, each as finally fitted and refined.
void choose_final(Batch& b, std::size_t s) {
  const FitSettings& fit = b.fit;
  if (b.best[s].ok) {
    std::vector<Candidate> three;  // and the fit beyond a stalled walk
    std::vector<const Fitted*> fits;
    for (const Fitted* f : {&b.below[s], &b.best[s], &b.above[s], &b.beyond[s]})
      if (f->ok) {
        three.push_back({f->gmm.k(), f->l1, true});
        fits.push_back(f);
      }
    const Fitted* won = fits[choose_candidate(three, fit.k_penalty, fit.error_target)];
    if (won != &b.best[s]) {
      b.chosen[s] = won->gmm.k();
      b.best[s] = *won;
    }
  }
  b.mark_chosen(s);
}

// The final fits of `tasks` (role as final_tasks made them) and, with K pinned, of
// `first` followed by split-and-merge rounds: each offered to its slice or kept as the
// slice's fit below or above when better.
void run_final(Batch& b, const std::vector<EmTask>& tasks, const std::vector<EmTask>& first,
               const std::vector<int>& role) {
  if (!first.empty()) {  // pinned K
    const std::vector<EmResult> res = split_merge_fit(engine_fitter(b.engine), b.full_set, first, SmemSettings{});
    for (std::size_t i = 0; i < res.size(); ++i) b.offer(first[i].slice, evaluate(res[i], b.work[first[i].slice].full));
  }
  if (tasks.empty()) return;
  const std::vector<EmResult> results = b.engine.fit(b.full_set, tasks);
  std::vector<Fitted> fitted(results.size());
  run_on_workers(results.size(), std::min<std::size_t>(results.size(), host_threads()),
                 [&](std::size_t, std::size_t i) { fitted[i] = evaluate(results[i], b.work[tasks[i].slice].full); });
  for (std::size_t i = 0; i < results.size(); ++i) {
    const std::size_t s = tasks[i].slice;
    Fitted& side = role[i] == 1 ? b.below[s] : b.above[s];
    if (role[i] == 0) b.offer(s, fitted[i]);
    else if (fitted[i].ok && fitted[i].l1 < side.l1) side = fitted[i];
  }
}

}  // namespace

// The final fits of the walk: as Batch::final_fits, but restart 0 starts from the
// search's fit of the chosen K (when K is pinned: k-means++ followed by split-and-merge
// rounds), and the candidate Ks just below and just above the chosen one are refitted as
// long, from their search fits, refined like it, and chosen instead when the score is
// now the better one (EM separates overlapping lobes slowly: a search fit of the true K
// can stop short of it; and the search compares EM's fits, whose L1 error the
// refinement can cut by more at the K above than the penalty of its components); and a
// walk that stalled with a poor best fit is fitted past its last K as well.
void final_smem(Batch& b) {
  std::vector<EmTask> tasks, first;
  std::vector<int> role;  // per task: 0 a restart of the chosen K, 1 the K below, 2 the K above
  {
    const PhaseTimer t(b.phases.final_em);
    final_tasks(b, tasks, first, role);
  }
  {
    const PhaseTimer t(b.phases.beyond);
    fit_beyond(b);
  }
  {
    const PhaseTimer t(b.phases.final_em);
    run_final(b, tasks, first, role);
  }
  {
    const PhaseTimer t(b.phases.refine);
    b.refine(true);
  }
  for (std::size_t s = 0; s < b.size(); ++s) choose_final(b, s);
}

}  // namespace bsdfmix
