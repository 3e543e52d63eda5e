// The fitting sweep: Gaussian-count search, final fits, crash-safe batches, outputs.
#include "sweep/sweep.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>
#include <unordered_map>
#include <thread>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "core/hash.hpp"
#include "core/output_lock.hpp"
#include "core/progress.hpp"
#include "device/device.hpp"
#include "device/program.hpp"
#include "fit/em.hpp"
#include "fit/em_internal.hpp"
#include "fit/moment_gaussian.hpp"
#include "fit/scheduler.hpp"
#include "fit/smem.hpp"
#include "io/table.hpp"
#include "sweep/checkpoint.hpp"
#include "sweep/criterion.hpp"
#include "sweep/fit_error.hpp"
#include "sweep/slice_plan.hpp"

namespace bsdfmix {

namespace {

// The fit report's columns (docs/formats.md, "Fit report"), the last `status`: ok, zero
// (an all-zero slice, stored with scale 0), reduced (K lowered to the number of non-zero
// cells) or failed (a moment-matched Gaussian stands in), each with its reason.
constexpr const char* kReportHeader = "slice,theta_o,phi_o,k,iterations,loglik,l1_rel,seconds,device,status\n";
constexpr const char* kSearchHeader = "slice,k,restart,loglik,l1_rel,score,chosen\n";

std::uint64_t splitmix(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

// The seed of one (slice, K, restart) problem: independent of batching and devices.
std::uint64_t task_seed(std::uint64_t seed, std::size_t slice, int k, int restart) {
  return splitmix(splitmix(splitmix(seed) ^ slice) ^ (std::uint64_t(k) << 32 | std::uint32_t(restart)));
}

std::string num(double v, const char* f = "%.9g") {
  char buf[64];
  std::snprintf(buf, sizeof buf, f, std::isfinite(v) ? v : 0.0);
  return buf;
}

// The devices a sweep runs on, as the report's `device` column names them.
std::string joined_names(const std::vector<Device>& devices) {
  std::string n;
  for (const auto& d : devices) n += (n.empty() ? "" : "+") + d.info().name;
  return n;
}


// One fit of a slice, with its relative L1 error at full resolution.
struct Fitted {
  bool ok = false;
  std::string failure;  // why, when !ok
  Gmm gmm;
  double loglik = 0, l1 = 0;
  int iterations = 0;
};

Fitted evaluate(const EmResult& r, const WeightedSlice& full) {
  Fitted f;
  if (!r.ok) {
    f.failure = r.failure;
    return f;
  }
  try {
    f.l1 = l1_rel_error(full, make_slice_mixture(r.gmm.weight, r.gmm.mean, r.gmm.cov));
  } catch (const std::exception&) {
    f.failure = "a covariance is not positive definite";
    return f;
  }
  f.ok = std::isfinite(f.l1) && std::isfinite(r.loglik);
  for (const auto* v : {&r.gmm.weight, &r.gmm.mean, &r.gmm.cov})
    for (double x : *v) f.ok = f.ok && std::isfinite(x);
  f.gmm = r.gmm;
  f.loglik = r.loglik;
  f.iterations = r.iterations;
  return f;
}

EmTask make_task(std::size_t slice, int k, int iterations, double tolerance, std::uint64_t seed) {
  EmTask t;
  t.slice = slice;
  t.k = k;
  t.settings.iterations = iterations;
  t.settings.tolerance = tolerance;
  t.settings.restarts = 1;
  t.settings.seed = seed;
  return t;
}

struct SliceWork {
  SliceRef ref;
  WeightedSlice full, pooled;
  double total = 0;
};

SliceSet make_set(Domain domain, const std::vector<SliceWork>& work, bool pooled) {
  SliceSet set;
  const WeightedSlice& first = pooled ? work.front().pooled : work.front().full;
  set.grid.domain = domain;
  set.grid.theta = first.theta;
  set.grid.phi = first.phi;
  for (const auto& w : work) set.weights.push_back(pooled ? w.pooled.w : w.full.w);
  return set;
}

// The fitting of one batch of slices: search, final fits, fallbacks, then its part.
class BatchFitter {
 public:
  BatchFitter(const TableMeta& meta, const FitSection& fit, EmEngine& engine, std::string device_names)
      : meta_(meta), fit_(fit), engine_(engine), devices_(std::move(device_names)),
        ks_(candidate_ks(fit.k_min, fit.k_max)) {}

  BatchPart fit(const TableReader& reader, const std::vector<SliceRef>& refs) {
    const auto start = std::chrono::steady_clock::now();
    load(reader, refs);
    if (fit_.k_min != fit_.k_max) {
      if (fit_.search == SearchStrategy::Smem) search_walk();
      else search();
    }
    if (fit_.search == SearchStrategy::Smem) {
      final_walk();
    } else {
      final_fits();
      refine(false);
    }
    reduce_k();
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return part(seconds);
  }

 private:
  void load(const TableReader& reader, const std::vector<SliceRef>& refs) {
    work_.clear();
    Hash64 content;
    for (const SliceRef& ref : refs) {
      SliceWork w;
      w.ref = ref;
      const auto f = reader.read_slice(ref.t_o, ref.p_o);
      content.update(f.data(), f.size() * sizeof(float));
      w.full.theta = meta_.theta_i;
      w.full.phi = meta_.phi_i;
      w.full.w = integrand_weights(meta_.domain, meta_.theta_i, meta_.phi_i, f.data());
      w.total = w.full.total();
      w.pooled = pool_slice(w.full, std::size_t(fit_.search_pool));
      work_.push_back(std::move(w));
    }
    slices_hash_ = content.hex();
    const std::size_t n = work_.size();
    full_set_ = make_set(meta_.domain, work_, false);
    chosen_.assign(n, fit_.k_min);
    best_.assign(n, Fitted{});
    below_.assign(n, Fitted{});
    walk_rows_.assign(n, {});
    failure_.assign(n, std::string());
    reduced_from_.assign(n, 0);
    search_rows_.str("");
  }

  // Keeps `f` as the slice's fit when it is usable and has a lower L1 error.
  void offer(std::size_t s, const Fitted& f) {
    if (f.ok && (!best_[s].ok || f.l1 < best_[s].l1)) best_[s] = f;
    if (!f.ok && failure_[s].empty()) failure_[s] = f.failure;
  }

  // Every candidate K and restart of every slice in one submission; the criterion
  // picks each slice's K, and the best restart of that K is its fit so far.
  void search() {
    std::vector<EmTask> tasks;
    for (std::size_t s = 0; s < work_.size(); ++s) {
      if (!(work_[s].total > 0)) continue;
      for (int k : ks_)
        for (int r = 0; r < fit_.restarts; ++r)
          tasks.push_back(make_task(s, k, fit_.iterations, fit_.tolerance, task_seed(fit_.seed, work_[s].ref.index, k, r)));
    }
    const std::vector<EmResult> results =
        engine_.fit(fit_.search_pool > 1 ? make_set(meta_.domain, work_, true) : full_set_, tasks);
    std::size_t ti = 0;
    for (std::size_t s = 0; s < work_.size(); ++s) {
      if (!(work_[s].total > 0)) continue;
      std::vector<Candidate> cands;
      std::vector<Fitted> per_k;  // the best restart of each candidate
      std::vector<std::string> rows;
      for (int k : ks_) {
        Candidate c{k, 1e300, false};
        Fitted kbest;
        for (int r = 0; r < fit_.restarts; ++r, ++ti) {
          const Fitted f = evaluate(results[ti], work_[s].full);
          if (f.ok && f.l1 < c.l1_rel) {
            c.ok = true;
            c.l1_rel = f.l1;
            kbest = f;
          }
          const double l1 = f.ok ? f.l1 : 2.0;  // a failed restart: the worst error
          rows.push_back(std::to_string(work_[s].ref.index) + "," + std::to_string(k) + "," + std::to_string(r) + "," +
                         num(f.ok ? f.loglik : 0.0) + "," + num(l1) + "," + num(candidate_score(k, l1, fit_.k_penalty)) +
                         ",");
        }
        cands.push_back(c);
        per_k.push_back(kbest);
      }
      std::size_t pick = 0;
      try {
        pick = choose_candidate(cands, fit_.k_penalty, fit_.error_target);
      } catch (const Error&) {
        pick = 0;  // every candidate failed: the final fits try k_min
      }
      chosen_[s] = cands[pick].k;
      best_[s] = per_k[pick];
      std::size_t row = 0;
      for (int k : ks_)
        for (int r = 0; r < fit_.restarts; ++r, ++row) search_rows_ << rows[row] << (k == chosen_[s] ? "1" : "0") << "\n";
    }
  }

  // The walk over K of `search: smem` (docs/fitting.md). Every slice of the batch walks
  // the candidate Ks upwards together: the first K starts from k-means++ restarts, each
  // later K from the previous K's fit grown by splitting its worst-fitting components;
  // after EM, split-and-merge rounds move components out of local optima. Each step is
  // a batched engine call over the slices still walking. A slice stops walking once no
  // larger K can win: its best score is at most k_penalty times the next K (l1_rel >= 0),
  // or, with an error target, once a K meets it; and (a heuristic) when its best score has
  // not improved over the last kWalkPatience candidates.
  static constexpr int kWalkPatience = 2;
  void search_walk() {
    const bool pooled = fit_.search_pool > 1;
    const SliceSet pooled_set = pooled ? make_set(meta_.domain, work_, true) : SliceSet{};
    const SliceSet& set = pooled ? pooled_set : full_set_;
    const std::size_t n = work_.size();
    const EmFitter fitter = [this](const SliceSet& ss, const std::vector<EmTask>& t) { return engine_.fit(ss, t); };
    const std::size_t threads = std::max(1u, std::thread::hardware_concurrency());
    const SmemSettings smem;
    struct Walk {
      bool active = false;
      EmResult cur;  // the fit of the last K walked
      std::vector<Candidate> cands;
      std::vector<Fitted> per_k;
      std::vector<std::string> rows;  // search CSV rows but the `chosen` column
      double best_score = 1e300;
      int since_best = 0;  // candidates walked since the best score last improved
    };
    std::vector<Walk> walk(n);
    for (std::size_t s = 0; s < n; ++s) walk[s].active = work_[s].total > 0;
    for (std::size_t ki = 0; ki < ks_.size(); ++ki) {
      const int k = ks_[ki];
      std::vector<std::size_t> live;
      for (std::size_t s = 0; s < n; ++s)
        if (walk[s].active) live.push_back(s);
      if (live.empty()) break;
      // The start of K for every walking slice (grown on the host, in parallel).
      std::vector<EmTask> tasks(live.size());
      run_on_workers(live.size(), std::min(threads, live.size()), [&](std::size_t, std::size_t i) {
        const std::size_t s = live[i];
        EmTask t = make_task(s, k, fit_.iterations, fit_.tolerance, task_seed(fit_.seed, work_[s].ref.index, k, 0));
        const EmResult& prev = walk[s].cur;
        if (ki > 0 && prev.ok && prev.gmm.k() < k) {
          const ComponentScores sc = score_components(set.grid, set.weights[s], prev.gmm, 0);
          t.init = grow_mixture(prev.gmm, sc, k, em_detail::cov_floor(set.grid, t.settings));
        } else {
          t.settings.restarts = fit_.restarts;  // no fit to grow: k-means++ restarts
        }
        tasks[i] = std::move(t);
      });
      const std::vector<EmResult> res = split_merge_fit(fitter, set, tasks, smem);
      std::vector<Fitted> fitted(live.size());
      run_on_workers(live.size(), std::min(threads, live.size()),
                     [&](std::size_t, std::size_t i) { fitted[i] = evaluate(res[i], work_[live[i]].full); });
      for (std::size_t i = 0; i < live.size(); ++i) {
        const std::size_t s = live[i];
        Walk& wk = walk[s];
        wk.cur = res[i];
        const Fitted& f = fitted[i];
        wk.cands.push_back(Candidate{k, f.ok ? f.l1 : 1e300, f.ok});
        wk.per_k.push_back(f);
        const double l1 = f.ok ? f.l1 : 2.0;
        if (f.ok && candidate_score(k, f.l1, fit_.k_penalty) < wk.best_score) {
          wk.best_score = candidate_score(k, f.l1, fit_.k_penalty);
          wk.since_best = 0;
        } else {
          ++wk.since_best;
        }
        if (!fit_.error_target && wk.since_best >= kWalkPatience) wk.active = false;
        wk.rows.push_back(std::to_string(work_[s].ref.index) + "," + std::to_string(k) + ",0," +
                          num(f.ok ? f.loglik : 0.0) + "," + num(l1) + "," +
                          num(candidate_score(k, l1, fit_.k_penalty)) + ",");
        if (fit_.error_target ? f.ok && f.l1 <= *fit_.error_target
                              : ki + 1 < ks_.size() && wk.best_score <= fit_.k_penalty * ks_[ki + 1])
          wk.active = false;
      }
    }
    for (std::size_t s = 0; s < n; ++s) {
      Walk& wk = walk[s];
      if (wk.cands.empty()) continue;
      std::size_t pick = 0;
      try {
        pick = choose_candidate(wk.cands, fit_.k_penalty, fit_.error_target);
      } catch (const Error&) {
        pick = 0;  // every candidate failed: the final fits try k_min
      }
      chosen_[s] = wk.cands[pick].k;
      best_[s] = wk.per_k[pick];
      if (pick > 0 && wk.per_k[pick - 1].ok) below_[s] = wk.per_k[pick - 1];
      for (std::size_t r = 0; r < wk.rows.size(); ++r) walk_rows_[s].emplace_back(wk.cands[r].k, wk.rows[r]);
    }
  }

  // The chosen K of every slice at full resolution, with more restarts and iterations;
  // the lowest L1 error among them and the search's fits of that K is kept.
  void final_fits() {
    std::vector<EmTask> tasks;
    for (std::size_t s = 0; s < work_.size(); ++s) {
      if (!(work_[s].total > 0)) continue;
      for (int r = 0; r < fit_.final_restarts; ++r)
        tasks.push_back(make_task(s, chosen_[s], fit_.final_iterations, fit_.tolerance,
                                  task_seed(fit_.seed, work_[s].ref.index, chosen_[s], -1 - r)));
    }
    run(tasks);
  }

  // The final fits of `search: smem`: as final_fits, but restart 0 starts from the
  // search's fit of the chosen K (when K is pinned: k-means++ followed by split-and-merge
  // rounds), and the candidate K just below the chosen one is refitted as long, from its
  // search fit, and chosen instead when its score is now the better one (EM separates
  // overlapping lobes slowly: a search fit of the true K can stop short of it).
  void final_walk() {
    const std::size_t n = work_.size();
    std::vector<EmTask> tasks, first;
    std::vector<int> role;  // per task: 0 a restart of the chosen K, 1 the K below
    for (std::size_t s = 0; s < n; ++s) {
      if (!(work_[s].total > 0)) continue;
      for (int r = 0; r < fit_.final_restarts; ++r) {
        EmTask t = make_task(s, chosen_[s], fit_.final_iterations, fit_.tolerance,
                             task_seed(fit_.seed, work_[s].ref.index, chosen_[s], -1 - r));
        if (r == 0 && best_[s].ok && best_[s].gmm.k() == chosen_[s]) t.init = best_[s].gmm;
        if (r == 0 && fit_.k_min == fit_.k_max) {
          first.push_back(std::move(t));
          continue;
        }
        tasks.push_back(std::move(t));
        role.push_back(0);
      }
      if (below_[s].ok) {
        EmTask t = make_task(s, below_[s].gmm.k(), fit_.final_iterations, fit_.tolerance,
                             task_seed(fit_.seed, work_[s].ref.index, below_[s].gmm.k(), -1));
        t.init = below_[s].gmm;
        tasks.push_back(t);
        role.push_back(1);
        // And the chosen fit with its two most overlapping components merged (a lobe
        // the search split in two while it had not yet separated two others).
        if (best_[s].ok && best_[s].gmm.k() == below_[s].gmm.k() + 1) {
          const ComponentScores sc = score_components(full_set_.grid, full_set_.weights[s], best_[s].gmm, 1);
          if (!sc.merge.empty()) {
            t.init = merge_components(best_[s].gmm, sc.merge[0].first, sc.merge[0].second);
            tasks.push_back(std::move(t));
            role.push_back(1);
          }
        }
      }
    }
    if (!first.empty()) {  // pinned K
      const EmFitter fitter = [this](const SliceSet& ss, const std::vector<EmTask>& t) { return engine_.fit(ss, t); };
      const std::vector<EmResult> res = split_merge_fit(fitter, full_set_, first, SmemSettings{});
      for (std::size_t i = 0; i < res.size(); ++i) offer(first[i].slice, evaluate(res[i], work_[first[i].slice].full));
    }
    if (!tasks.empty()) {
      const std::vector<EmResult> results = engine_.fit(full_set_, tasks);
      std::vector<Fitted> fitted(results.size());
      run_on_workers(results.size(), std::min<std::size_t>(results.size(), std::max(1u, std::thread::hardware_concurrency())),
                     [&](std::size_t, std::size_t i) { fitted[i] = evaluate(results[i], work_[tasks[i].slice].full); });
      for (std::size_t i = 0; i < results.size(); ++i) {
        const std::size_t s = tasks[i].slice;
        if (role[i] == 0) offer(s, fitted[i]);
        else if (fitted[i].ok && fitted[i].l1 < below_[s].l1) below_[s] = fitted[i];
      }
    }
    refine(true);
    for (std::size_t s = 0; s < n; ++s) {
      if (below_[s].ok && best_[s].ok) {
        const std::vector<Candidate> two = {{below_[s].gmm.k(), below_[s].l1, true}, {chosen_[s], best_[s].l1, true}};
        if (choose_candidate(two, fit_.k_penalty, fit_.error_target) == 0) {
          chosen_[s] = below_[s].gmm.k();
          best_[s] = below_[s];
        }
      }
      for (const auto& [k, row] : walk_rows_[s]) search_rows_ << row << (k == chosen_[s] ? "1" : "0") << "\n";
    }
  }

  // The L1 refinement (fit/l1_refine.hpp) of every slice's kept fit and, with `below`,
  // of the candidate K below it (final_walk compares the two after). A refined mixture
  // replaces its start only when its relative L1 error (sweep/fit_error.cpp, the exact
  // periodic density) is lower; its log-likelihood is recomputed.
  void refine(bool below) {
    if (fit_.refine != "l1") return;
    std::vector<L1Query> queries;
    std::vector<Fitted*> owners;
    for (std::size_t s = 0; s < work_.size(); ++s) {
      if (best_[s].ok) {
        queries.push_back({s, best_[s].gmm});
        owners.push_back(&best_[s]);
      }
      if (below && s < below_.size() && below_[s].ok) {
        queries.push_back({s, below_[s].gmm});
        owners.push_back(&below_[s]);
      }
    }
    if (queries.empty()) return;
    const EmEngine::L1Slices slices = EmEngine::l1_prepare(full_set_);  // once, not per evaluation
    const L1Evaluator evaluate = [&](const SliceSet&, const std::vector<L1Query>& q, const L1Objective& o) {
      return engine_.l1_values(slices, q, o);
    };
    const std::vector<Gmm> refined =
        refine_l1(evaluate, full_set_, queries, RefineSettings{fit_.refine_evaluations, fit_.refine_kl});
    const std::size_t threads = std::min<std::size_t>(queries.size(), std::max(1u, std::thread::hardware_concurrency()));
    run_on_workers(queries.size(), threads, [&](std::size_t, std::size_t i) {
      const std::size_t s = queries[i].slice;
      const Gmm& g = refined[i];
      double l1;
      try {
        l1 = l1_rel_error(work_[s].full, make_slice_mixture(g.weight, g.mean, g.cov));
      } catch (const std::exception&) {
        return;  // not positive definite in double: keep the start
      }
      Fitted& f = *owners[i];
      if (!(l1 < f.l1)) return;
      f.gmm = g;
      f.l1 = l1;
      f.loglik = em_detail::weighted_loglik(full_set_.grid, em_detail::prepare_slice(full_set_, s).w, g);
    });
  }

  // A slice with fewer non-zero cells than K cannot hold K components: it is refitted
  // with one component per non-zero cell.
  void reduce_k() {
    std::vector<EmTask> tasks;
    for (std::size_t s = 0; s < work_.size(); ++s) {
      if (best_[s].ok || !(work_[s].total > 0)) continue;
      const int positive = static_cast<int>(
          std::count_if(work_[s].full.w.begin(), work_[s].full.w.end(), [](double x) { return x > 0; }));
      if (positive >= chosen_[s]) continue;
      reduced_from_[s] = chosen_[s];
      chosen_[s] = positive;
      for (int r = 0; r < fit_.final_restarts; ++r)
        tasks.push_back(make_task(s, positive, fit_.final_iterations, fit_.tolerance,
                                  task_seed(fit_.seed, work_[s].ref.index, positive, -1 - r)));
    }
    run(tasks);
  }

  void run(const std::vector<EmTask>& tasks) {
    if (tasks.empty()) return;
    const std::vector<EmResult> results = engine_.fit(full_set_, tasks);
    for (std::size_t i = 0; i < results.size(); ++i) offer(tasks[i].slice, evaluate(results[i], work_[tasks[i].slice].full));
  }

  std::string status(std::size_t s) const {
    std::string st = "ok";
    if (!(work_[s].total > 0)) {
      st = "zero: every cell is zero; stored with scale 0";
    } else if (!best_[s].ok) {
      st = "failed: " + (failure_[s].empty() ? std::string("no usable fit") : failure_[s]) +
           "; one moment-matched Gaussian stands in";
    } else if (reduced_from_[s] > 0) {
      st = "reduced: K lowered from " + std::to_string(reduced_from_[s]) + " to " + std::to_string(chosen_[s]) +
           ", the number of non-zero cells";
    }
    std::replace(st.begin(), st.end(), ',', ';');
    return st;
  }

  BatchPart part(double seconds) const {
    BatchPart part;
    part.mixture.domain = meta_.domain;
    part.mixture.azimuthal = meta_.azimuthal;
    std::ostringstream report;
    for (std::size_t s = 0; s < work_.size(); ++s) {
      const SliceWork& w = work_[s];
      Fitted f = best_[s];
      const std::string st = status(s);
      if (!f.ok) {  // zero slice or failed fit: one moment-matched Gaussian
        f.gmm = moment_gaussian(full_set_.grid, w.full.w);
        f.l1 = w.total > 0 ? l1_rel_error(w.full, make_slice_mixture(f.gmm.weight, f.gmm.mean, f.gmm.cov)) : 0.0;
        f.loglik = 0;
        f.iterations = 0;
      }
      const double theta_o = meta_.theta_o[w.ref.t_o], phi_o = meta_.phi_o[w.ref.p_o];
      part.slice_index.push_back(w.ref.index);
      part.mixture.add_slice(theta_o, phi_o, w.total, f.loglik, f.l1, f.gmm.weight, f.gmm.mean, f.gmm.cov);
      report << w.ref.index << "," << num(theta_o) << "," << num(phi_o) << "," << f.gmm.weight.size() << ","
             << f.iterations << "," << num(f.loglik) << "," << num(f.l1) << ","
             << num(seconds / double(work_.size()), "%.6f") << "," << devices_ << "," << st << "\n";
      if (st != "ok") log_line("slice " + std::to_string(w.ref.index) + ": " + st);
    }
    part.report_rows = report.str();
    part.search_rows = search_rows_.str();
    part.slices_hash = slices_hash_;
    return part;
  }

  const TableMeta& meta_;
  const FitSection& fit_;
  EmEngine& engine_;
  const std::string devices_;
  const std::vector<int> ks_;
  std::vector<SliceWork> work_;
  SliceSet full_set_;
  std::vector<int> chosen_, reduced_from_;
  std::vector<Fitted> best_;
  std::vector<Fitted> below_;  // search: smem: the search's fit of the candidate K below the chosen one
  std::vector<std::vector<std::pair<int, std::string>>> walk_rows_;  // search: smem: (K, CSV row but `chosen`)
  std::vector<std::string> failure_;
  std::ostringstream search_rows_;
  std::string slices_hash_;
};

// The final outputs, assembled from the committed parts in slice order.
SweepSummary write_outputs(const Checkpoint& checkpoint, const std::string& table_path, const TableMeta& meta,
                           const FitSection& fit) {
  MixtureFile out;
  out.domain = meta.domain;
  out.azimuthal = meta.azimuthal;
  out.table_source = meta.source;
  out.fit_settings = fit_settings_json(fit);
  out.table_theta_o = meta.theta_o;
  out.table_phi_o = meta.phi_o;
  std::string report = kReportHeader, search_csv = kSearchHeader;
  SweepSummary sum;
  std::vector<double> l1s;
  for (const auto& [first, part] : checkpoint.parts()) {
    const MixtureFile& m = part.mixture;
    for (std::size_t s = 0; s < m.slices(); ++s) {
      std::vector<double> w, mean, cov;
      m.slice_params(s, w, mean, cov);
      out.add_slice(m.theta_o[s], m.phi_o[s], m.scale[s], m.loglik[s], m.l1_rel[s], w, mean, cov);
      sum.k_histogram[m.k[s]]++;
      l1s.push_back(m.l1_rel[s]);
    }
    report += part.report_rows;
    for (std::size_t at = part.report_rows.find(",failed: "); at != std::string::npos;
         at = part.report_rows.find(",failed: ", at + 1))
      ++sum.failed;
    search_csv += part.search_rows;
  }
  write_mixture_file(fit.output, out);
  write_text_atomic(fit.report, report);
  write_text_atomic(fit.search_report, search_csv);

  sum.slices = out.slices();
  std::sort(l1s.begin(), l1s.end());
  if (!l1s.empty()) {
    sum.l1_median = l1s[l1s.size() / 2];
    sum.l1_p90 = l1s[std::min(l1s.size() - 1, std::size_t(std::ceil(0.9 * double(l1s.size()))) - 1)];
    sum.l1_max = l1s.back();
  }
  sum.mixture_file_bytes = std::filesystem::file_size(fit.output);
  sum.mixture_bytes = out.payload_bytes();
  sum.table_file_bytes = std::filesystem::file_size(table_path);
  sum.table_slices = meta.theta_o.size() * meta.phi_o.size();
  sum.table_bytes = std::uint64_t(sum.slices) * meta.cells_per_slice() * sizeof(float);
  sum.symmetry_factor = meta.azimuthal ? meta.phi_i.size() : 1;
  sum.full_bytes = sum.table_bytes * sum.symmetry_factor;
  return sum;
}

// What makes a checkpoint reusable: the table (path, size, source; its content is
// checked part by part), the slices planned and the batching, every fit setting, the
// build (the executable's and the EM kernel's bytes) and the numeric path (devices,
// drivers, precision).
std::string sweep_fingerprint(const std::string& table_path, const TableMeta& meta, const std::vector<SliceRef>& plan,
                              const FitSection& fit, std::size_t batch, const EmEngine& engine,
                              const std::vector<Device>& devices) {
  static const std::string executable = hex64(hash_file("/proc/self/exe"));
  const std::string em_source = kernel_source("em");
  std::ostringstream fp;
  fp << "table " << std::filesystem::absolute(table_path).string() << " size " << std::filesystem::file_size(table_path)
     << " source " << meta.source << "\nslices";
  for (const auto& r : plan) fp << ' ' << r.index;
  fp << "\nsettings " << fit_settings_json(fit) << "\nbatch " << batch << "\nbuild bsdfmix " << BSDFMIX_VERSION
     << " executable " << executable << " em.cl " << Hash64().update(em_source.data(), em_source.size()).hex()
     << "\nnumeric path";
  for (std::size_t d = 0; d < devices.size(); ++d)
    fp << " [" << devices[d].info().name << " | " << devices[d].info().platform << " | "
       << devices[d].info().version << " | " << devices[d].info().driver << " | "
       << (engine.uses_fp64(d) ? "fp64" : "fp32") << "]";
  fp << "\n";
  return fp.str();
}

}  // namespace

std::string fit_settings_json(const FitSection& f) {
  std::ostringstream s;
  s << "{\"k_min\": " << f.k_min << ", \"k_max\": " << f.k_max << ", \"seed\": " << f.seed
    << ", \"restarts\": " << f.restarts << ", \"final_restarts\": " << f.final_restarts
    << ", \"iterations\": " << f.iterations << ", \"final_iterations\": " << f.final_iterations
    << ", \"tolerance\": " << num(f.tolerance) << ", \"k_penalty\": " << num(f.k_penalty)
    << ", \"error_target\": " << (f.error_target ? num(*f.error_target) : "null")
    << ", \"search_pool\": " << f.search_pool << ", \"search\": \"" << search_name(f.search)
    << "\", \"refine\": \"" << f.refine << "\", \"refine_evaluations\": " << f.refine_evaluations
    << ", \"refine_kl\": " << num(f.refine_kl)
    << ", \"criterion\": \"l1_rel + k_penalty * K\"}";
  return s.str();
}

std::string SweepSummary::text() const {
  auto size = [](double b) {
    char buf[32];
    const char* u[] = {"B", "KiB", "MiB", "GiB", "TiB"};
    int i = 0;
    while (b >= 1024 && i < 4) b /= 1024, ++i;
    std::snprintf(buf, sizeof buf, "%.1f %s", b, u[i]);
    return std::string(buf);
  };
  std::ostringstream s;
  std::size_t total_k = 0;
  s << "  slices           " << slices << " fitted (" << resumed << " resumed from checkpoint, " << failed
    << " failed)\n  K per slice     ";
  for (auto [k, n] : k_histogram) {
    s << " " << k << "x" << n;
    total_k += std::size_t(k) * n;
  }
  char buf[256];
  std::snprintf(buf, sizeof buf, " (mean %.1f)\n", slices ? double(total_k) / double(slices) : 0.0);
  s << buf;
  std::snprintf(buf, sizeof buf, "  relative L1      median %.2f%%, p90 %.2f%%, max %.2f%%\n", 100 * l1_median,
                100 * l1_p90, 100 * l1_max);
  s << buf;
  auto ratio = [](std::uint64_t a, std::uint64_t b) { return num(double(a) / double(std::max<std::uint64_t>(b, 1)), "%.0f") + "x"; };
  s << "  mixture          file " << size(double(mixture_file_bytes)) << " on disk, datasets " << size(double(mixture_bytes))
    << " (padded to the largest K)\n";
  s << "  table            file " << size(double(table_file_bytes)) << " on disk";
  if (table_slices == slices) s << " (" << ratio(table_file_bytes, mixture_file_bytes) << " the mixture file)";
  else s << " holding " << table_slices << " slices";
  s << ", float32 cells of the fitted slices " << size(double(table_bytes)) << " ("
    << ratio(table_bytes, mixture_bytes) << " the mixture's datasets)\n";
  if (symmetry_factor > 1)
    s << "  symmetry         azimuthal: one stored slice stands for " << symmetry_factor
      << " phi_o; without it those cells would be " << size(double(full_bytes)) << " ("
      << ratio(full_bytes, mixture_bytes) << " the mixture's datasets)\n";
  std::snprintf(buf, sizeof buf, "  wall time        %.1f s on %s\n", seconds, devices.c_str());
  s << buf;
  return s.str();
}

namespace {
BatchFarm* g_batch_farm = nullptr;
}  // namespace

void set_batch_farm(BatchFarm* farm) { g_batch_farm = farm; }

struct BatchWorker::Impl {
  Impl(const std::string& table_path, const FitSection& fit, const std::string& device_selector)
      : fit_settings(fit), reader(table_path), devices(select_devices(device_selector)),
        names(joined_names(devices)),
        engine(devices), fitter(reader.meta(), fit_settings, engine, names) {}
  const FitSection fit_settings;
  TableReader reader;
  const std::vector<Device> devices;
  const std::string names;
  EmEngine engine;
  BatchFitter fitter;
};

BatchWorker::BatchWorker(const std::string& table_path, const FitSection& fit, const std::string& device_selector)
    : impl_(std::make_unique<Impl>(table_path, fit, device_selector)) {}
BatchWorker::~BatchWorker() = default;
BatchPart BatchWorker::fit(const std::vector<SliceRef>& batch) { return impl_->fitter.fit(impl_->reader, batch); }

SweepSummary run_sweep(const std::string& table_path, const FitSection& fit, const std::string& device_selector,
                       std::size_t max_batches) {
  const auto t_start = std::chrono::steady_clock::now();
  const OutputLock lock(fit.output);  // a second run on the same output fails here, at once
  TableReader reader(table_path);
  const TableMeta& meta = reader.meta();
  const std::vector<SliceRef> plan = plan_slices(meta, fit.theta_o, fit.phi_o);
  for (const auto* out : {&fit.output, &fit.report, &fit.search_report}) prepare_output(*out, 1 << 20);

  const std::vector<Device> devices = select_devices(device_selector);
  const std::string device_names = joined_names(devices);
  EmEngine engine(devices);

  const std::size_t batch = fit.batch > 0 ? std::size_t(fit.batch)
                                          : std::clamp<std::size_t>(plan.size() / 32, 4, 64);
  Checkpoint checkpoint(fit.output, sweep_fingerprint(table_path, meta, plan, fit, batch, engine, devices));
  // A table rewritten in place (same path, size and source) is caught by its content.
  std::unordered_map<std::size_t, const SliceRef*> planned;
  for (const SliceRef& r : plan) planned.emplace(r.index, &r);
  checkpoint.verify([&](const std::vector<std::size_t>& indices) {
    Hash64 content;
    for (std::size_t index : indices) {
      const auto at = planned.find(index);
      if (at == planned.end()) return std::string("not planned");
      const auto f = reader.read_slice(at->second->t_o, at->second->p_o);
      content.update(f.data(), f.size() * sizeof(float));
    }
    return content.hex();
  });

  // Batches are fixed ranges of the plan, so a resumed sweep rebuilds exactly the
  // batches it did not commit: the same problems, the same results.
  std::vector<std::vector<SliceRef>> batches;
  std::size_t resumed = 0;
  for (std::size_t b0 = 0; b0 < plan.size(); b0 += batch) {
    std::vector<SliceRef> b(plan.begin() + b0, plan.begin() + std::min(plan.size(), b0 + batch));
    const bool done = std::all_of(b.begin(), b.end(), [&](const SliceRef& r) { return checkpoint.done(r.index); });
    if (done) resumed += b.size();
    else batches.push_back(std::move(b));
  }
  const std::vector<int> ks = candidate_ks(fit.k_min, fit.k_max);
  log_line("fit " + table_path + ": " + std::to_string(plan.size()) + " slice(s), " +
           (fit.k_min != fit.k_max ? std::to_string(ks.size()) + " candidate K in [" + std::to_string(fit.k_min) +
                                         ", " + std::to_string(fit.k_max) + "]"
                                   : "K = " + std::to_string(fit.k_min)) +
           ", on " + device_names);
  Progress progress("fit " + table_path, plan.size(), "slices");
  progress.advance(resumed);

  BatchFitter fitter(meta, fit, engine, device_names);
  std::size_t committed = resumed;
  const bool stops = max_batches < batches.size();
  if (stops) batches.resize(max_batches);
  const auto fit_here = [&](const std::vector<SliceRef>& b) { return fitter.fit(reader, b); };
  const auto commit = [&](BatchPart&& part) {
    checkpoint.commit(part);
    committed += part.slice_index.size();
    progress.advance(part.slice_index.size());
  };
  if (g_batch_farm) g_batch_farm->run(batches, fit_here, commit);
  else for (const auto& b : batches) commit(fit_here(b));
  if (stops) {
    SweepSummary partial;
    partial.complete = false;
    partial.resumed = resumed;
    partial.slices = committed;
    partial.devices = device_names;
    log_line("fit " + table_path + ": stopped after " + std::to_string(max_batches) + " batch(es); rerun to resume");
    return partial;
  }
  progress.finish();

  SweepSummary sum = write_outputs(checkpoint, table_path, meta, fit);
  checkpoint.remove();
  sum.resumed = resumed;
  sum.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  sum.devices = device_names;
  return sum;
}

}  // namespace bsdfmix
