// The fitting of one batch of slices: load, search (sweep/search_*.cpp), final fits,
// refinement, reduced K, fallbacks, then its part.
#include "sweep/batch_fitter.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <thread>

#include "core/hash.hpp"
#include "core/progress.hpp"
#include "fit/em_internal.hpp"
#include "fit/moment_gaussian.hpp"
#include "fit/scheduler.hpp"
#include "sweep/batch.hpp"
#include "sweep/criterion.hpp"
#include "sweep/earned_share.hpp"
#include "sweep/map_choice.hpp"
#include "sweep/stand_in.hpp"
#include "sweep/sweep.hpp"

namespace bsdfmix {

namespace {

SliceSet make_set(Domain domain, const std::vector<SliceWork>& work, bool pooled) {
  SliceSet set;
  const WeightedSlice& first = pooled ? work.front().pooled : work.front().full;
  set.grid.domain = domain;
  set.grid.map = first.map;
  set.grid.theta = first.theta;
  set.grid.phi = first.phi;
  for (const auto& w : work) set.weights.push_back(pooled ? w.pooled.w : w.full.w);
  return set;
}

// The report's `status` of slice s (docs/formats.md, "Fit report"): ok, zero (an
// all-zero slice, stored with scale 0), reduced (K lowered to the number of non-zero
// cells) or failed (a moment-matched Gaussian stands in), each with its reason.
std::string status(const Batch& b, std::size_t s) {
  std::string st = "ok";
  if (b.zero(s)) {
    st = "zero: every cell is zero; stored with scale 0";
  } else if (!b.best[s].ok) {
    st = "failed: " + (b.failure[s].empty() ? std::string("no usable fit") : b.failure[s]) +
         "; one moment-matched Gaussian stands in";
  } else if (b.reduced_from[s] > 0) {
    st = "reduced: K lowered from " + std::to_string(b.reduced_from[s]) + " to " + std::to_string(b.chosen[s]) +
         ", the number of non-zero cells";
  }
  std::replace(st.begin(), st.end(), ',', ';');
  return st;
}

}  // namespace

std::uint64_t task_seed(std::uint64_t seed, std::size_t slice, int k, int restart) {
  return splitmix64(splitmix64(splitmix64(seed) ^ slice) ^ (std::uint64_t(k) << 32 | std::uint32_t(restart)));
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

Batch::Batch(const FitSettings& fit_, EmEngine& engine_, Domain domain_)
    : fit(fit_), engine(engine_), domain(domain_), ks(candidate_ks(fit_.k_min, fit_.k_max)) {}

SliceSet Batch::pooled_set() const { return make_set(domain, work, true); }

SearchRow Batch::search_row(std::size_t s, int k, int restart, const Fitted& f) const {
  const double l1 = f.ok ? f.l1 : 2.0;  // a failed fit: the worst error
  return {work[s].ref.index, k, restart, f.ok ? f.loglik : 0.0, l1, candidate_score(k, l1, fit.k_penalty), false};
}

void Batch::mark_chosen(std::size_t s) {
  for (SearchRow& r : search_rows[s]) r.chosen = r.k == chosen[s];
}

void Batch::offer(std::size_t s, const Fitted& f) {
  if (f.ok && (!best[s].ok || f.l1 < best[s].l1)) best[s] = f;
  if (!f.ok && failure[s].empty()) failure[s] = f.failure;
}

void Batch::run(const std::vector<EmTask>& tasks) {
  if (tasks.empty()) return;
  const std::vector<EmResult> results = engine.fit(full_set, tasks);
  for (std::size_t i = 0; i < results.size(); ++i) offer(tasks[i].slice, evaluate(results[i], work[tasks[i].slice].full));
}

// The lowest L1 error among the final fits and the search's fits of that K is kept.
void Batch::final_fits() {
  std::vector<EmTask> tasks;
  for (std::size_t s = 0; s < size(); ++s) {
    if (zero(s)) continue;
    for (int r = 0; r < fit.final_restarts; ++r)
      tasks.push_back(make_task(s, chosen[s], fit.final_iterations, fit.tolerance,
                                task_seed(fit.seed, work[s].ref.index, chosen[s], -1 - r)));
  }
  run(tasks);
}

// The refinement of a fit above the chosen K (the K above, or beyond a stalled walk) is
// skipped when it cannot win: its score with its L1 error scaled by the chosen fit's
// refinement gain stays this far above the chosen fit's refined score. Measured on the RGL
// files and silk: the same fits as refining every one (docs/fitting.md, "The L1 refinement").
constexpr double kRefineMargin = 0.005;

// The L1 refinement (fit/l1_refine.hpp) of every slice's kept fit and, with `with_neighbours`,
// of the candidate K below it, then of those above it and beyond a stalled walk that can still
// win (kRefineMargin; final_smem compares them after). A refined mixture replaces its start
// only when its relative L1 error (sweep/fit_error.cpp, the exact periodic density) is lower;
// its log-likelihood is recomputed.
void Batch::refine(bool with_neighbours) {
  if (fit.refine != "l1") return;
  std::vector<L1Query> queries;
  std::vector<Fitted*> owners;
  const auto add = [&](std::size_t s, Fitted& f) {
    queries.push_back({s, f.gmm});
    owners.push_back(&f);
  };
  std::vector<double> unrefined(size(), 0.0);
  for (std::size_t s = 0; s < size(); ++s) {
    if (best[s].ok) {
      add(s, best[s]);
      unrefined[s] = best[s].l1;
    }
    if (with_neighbours && s < below.size() && below[s].ok) add(s, below[s]);
  }
  if (queries.empty()) return;
  const EmEngine::L1Slices slices = EmEngine::l1_prepare(full_set);  // once, not per evaluation
  refine_queries(slices, queries, owners);
  if (!with_neighbours) return;
  queries.clear();
  owners.clear();
  for (std::size_t s = 0; s < size(); ++s) {
    if (!best[s].ok) continue;
    const double gain = unrefined[s] > 0 ? best[s].l1 / unrefined[s] : 1.0;
    const double bar = candidate_score(best[s].gmm.k(), best[s].l1, fit.k_penalty) + kRefineMargin;
    for (std::vector<Fitted>* side : {&above, &beyond})
      if (s < side->size() && (*side)[s].ok &&
          candidate_score((*side)[s].gmm.k(), (*side)[s].l1 * gain, fit.k_penalty) < bar)
        add(s, (*side)[s]);
  }
  if (!queries.empty()) refine_queries(slices, queries, owners);
}

// The L1 refinement of `queries`; a refined mixture replaces its owner's fit only when
// its relative L1 error is lower.
void Batch::refine_queries(const EmEngine::L1Slices& slices, const std::vector<L1Query>& queries,
                           const std::vector<Fitted*>& owners) {
  const L1Evaluator l1_values = [&](const SliceSet&, const std::vector<L1Query>& q, const L1Objective& o) {
    return engine.l1_values(slices, q, o);
  };
  const std::vector<Gmm> refined =
      refine_l1(l1_values, full_set, queries, RefineSettings{fit.refine_evaluations, fit.refine_kl, fit.refine_rgb});
  const std::size_t threads = std::min<std::size_t>(queries.size(), std::max(1u, std::thread::hardware_concurrency()));
  run_on_workers(queries.size(), threads, [&](std::size_t, std::size_t i) {
    const std::size_t s = queries[i].slice;
    const Gmm& g = refined[i];
    double l1;
    try {
      l1 = l1_rel_error(work[s].full, make_slice_mixture(g.weight, g.mean, g.cov));
    } catch (const std::exception&) {
      return;  // not positive definite in double: keep the start
    }
    Fitted& f = *owners[i];
    if (!(l1 < f.l1)) return;
    f.gmm = g;
    f.l1 = l1;
    f.loglik = em_detail::weighted_loglik(full_set.grid, em_detail::prepare_slice(full_set, s).w, g);
  });
}

// A slice with fewer non-zero cells than K cannot hold K components: it is refitted
// with one component per non-zero cell.
void Batch::reduce_k() {
  std::vector<EmTask> tasks;
  for (std::size_t s = 0; s < size(); ++s) {
    if (best[s].ok || zero(s)) continue;
    const int positive =
        static_cast<int>(std::count_if(work[s].full.w.begin(), work[s].full.w.end(), [](double x) { return x > 0; }));
    if (positive >= chosen[s]) continue;
    reduced_from[s] = chosen[s];
    chosen[s] = positive;
    for (int r = 0; r < fit.final_restarts; ++r)
      tasks.push_back(make_task(s, positive, fit.final_iterations, fit.tolerance,
                                task_seed(fit.seed, work[s].ref.index, positive, -1 - r)));
  }
  run(tasks);
}

BatchFitter::BatchFitter(const SliceSource& source, const FitSettings& fit, EmEngine& engine, std::string device_names)
    : source_(source), fit_(fit), engine_(engine), devices_(std::move(device_names)) {}

Map fit_map(const FitSettings& fit, Domain d) {
  if (map_probed(fit, d)) throw std::logic_error("fit_map: fit.map auto is chosen by a probe first (sweep/map_choice.hpp)");
  return map_without_probe(fit, d) == "theta_phi" ? Map::ThetaPhi : mix::equal_area_map(d);
}

BatchPart BatchFitter::fit(const std::vector<SliceRef>& refs) {
  const auto start = std::chrono::steady_clock::now();
  BatchPart part;
  Batch b(fit_, engine_, source_.meta().domain);
  load(b, refs, part);
  const bool search = fit_.k_min != fit_.k_max;
  switch (fit_.search) {
    case SearchStrategy::Restarts:
      if (search) {
        const PhaseTimer t(b.phases.search);
        search_restarts(b);
      }
      {
        const PhaseTimer t(b.phases.final_em);
        b.final_fits();
      }
      {
        const PhaseTimer t(b.phases.refine);
        b.refine(false);
      }
      break;
    case SearchStrategy::Smem:
      if (search) {
        const PhaseTimer t(b.phases.search);
        search_smem(b);
      }
      final_smem(b);
      break;
  }
  {
    const PhaseTimer t(b.phases.final_em);
    b.reduce_k();
  }
  finish(b, std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), part);
  part.phases = b.phases;
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  part.phases.rest = std::max(0.0, seconds - b.phases.total());
  return part;
}

namespace {

// The Lambertian base off the slice's weights: the Gaussians are fitted to the rest, judged
// against the whole slice (WeightedSlice::reference_total, extra_error).
void take_base_off(SliceWork& w, const TableMeta& meta) {
  w.table = w.full;
  w.table_rgb = w.rgb;
  w.base = take_base(meta.theta_i, meta.phi_i.size(), axis_step(meta.theta_i), axis_step(meta.phi_i), w.full.w,
                     meta.rgb ? &w.rgb : nullptr);
  w.full.reference_total = w.table.total();
  w.full.extra_error = w.base.excess;
}

}  // namespace

void BatchFitter::load(Batch& b, const std::vector<SliceRef>& refs, BatchPart& part) const {
  const TableMeta& meta = source_.meta();
  Hash64 content;
  for (const SliceRef& ref : refs) {
    SliceWork w;
    w.ref = ref;
    w.full.theta = meta.theta_i;
    w.full.phi = meta.phi_i;
    w.full.map = fit_map(fit_, meta.domain);
    w.full.w = source_.weights(ref);
    hash_weights(content, w.full.w);
    if (meta.rgb) {
      w.rgb = source_.rgb_weights(ref);
      hash_weights(content, w.rgb);
    }
    if (w.full.map == Map::Disk) take_base_off(w, meta);
    w.total = w.full.total();
    w.pooled = pool_slice(w.full, std::size_t(fit_.search_pool));
    b.work.push_back(std::move(w));
  }
  part.slices_hash = content.hex();
  const std::size_t n = b.size();
  b.full_set = make_set(meta.domain, b.work, false);
  if (meta.rgb && fit_.refine == "l1" && fit_.refine_rgb > 0)  // the refinement weighs the channels too
    for (const SliceWork& w : b.work) b.full_set.rgb.push_back(w.rgb);
  b.chosen.assign(n, fit_.k_min);
  b.reduced_from.assign(n, 0);
  b.best.assign(n, Fitted{});
  b.below.assign(n, Fitted{});
  b.above.assign(n, Fitted{});
  b.beyond_k.assign(n, 0);
  b.beyond.assign(n, Fitted{});
  b.failure.assign(n, std::string());
  b.search_rows.assign(n, {});
}

void BatchFitter::finish(Batch& b, double seconds, BatchPart& part) const {
  const TableMeta& meta = source_.meta();
  part.mixture.domain = meta.domain;
  part.mixture.map = b.full_set.grid.map;
  part.mixture.azimuthal = meta.azimuthal;
  std::vector<Fitted> kept(b.size());
  std::vector<StandInSlice> stand;
  for (std::size_t s = 0; s < b.size(); ++s) {
    const SliceWork& w = b.work[s];
    Fitted& f = kept[s] = b.best[s];
    if (!f.ok) {  // zero slice or failed fit: one moment-matched Gaussian
      f.gmm = moment_gaussian(b.full_set.grid, w.full.w);
      f.loglik = 0;
      f.iterations = 0;
    }
    stand.push_back({&f.gmm, &w.full.w, meta.rgb ? &w.rgb : nullptr});
  }
  // The stand-ins on the kept Gaussians: the luminance's amplitudes become scale and weights.
  const std::vector<StandIn> stand_ins = fit_stand_ins(b.engine, b.full_set.grid, stand, fit_.rgb_copies ? *fit_.rgb_copies : -1.0);
  for (std::size_t s = 0; s < b.size(); ++s) {
    Fitted& f = kept[s];
    const SliceWork& w = b.work[s];
    // With a base: its amplitude beside the Gaussians', the weights shared out over both.
    // The Gaussians carry the rest less what the base's clamp added (SliceBase::excess),
    // so that the whole keeps the table's integral.
    const double rest = w.full.total(), keep = rest > 0 ? std::max(rest - w.base.excess, 0.0) / rest : 1.0;
    const double scale = stand_ins[s].scale * keep + w.base.lum;
    f.gmm.weight = stand_ins[s].weight;
    std::vector<double> weights = f.gmm.weight;
    if (w.base.lum > 0)
      for (double& x : weights) x *= stand_ins[s].scale * keep / scale;
    const double theta_o = meta.theta_o[w.ref.t_o], phi_o = meta.phi_o[w.ref.p_o];
    part.slice_index.push_back(w.ref.index);
    part.mixture.add_slice(theta_o, phi_o, scale, f.loglik, 0.0, weights, f.gmm.mean, f.gmm.cov,
                           meta.rgb ? &stand_ins[s].rgb : nullptr, &stand_ins[s].copies);
    if (w.base.lum > 0) part.mixture.set_base(w.base.lum / scale, w.base.rgb);
  }
  // Their errors as the header evaluates the slices stored (float32 parameters), the
  // uniform share each earns (sweep/earned_share.hpp) and the log-likelihood of the weights stored.
  std::vector<StandInError> errors(b.size());
  std::vector<EarnedShare> shares(b.size());
  const std::size_t first = part.mixture.slices() - b.size();
  const std::size_t threads = std::min<std::size_t>(b.size(), std::max(1u, std::thread::hardware_concurrency()));
  run_on_workers(b.size(), threads, [&](std::size_t, std::size_t s) {
    const SliceWork& w = b.work[s];
    const bool based = !w.table.w.empty();  // judged on the whole slice, the base included
    const mix::SliceMixture stored = slice_mixture(part.mixture, first + s);
    errors[s] = stand_in_error(based ? w.table : w.full, based ? w.table_rgb : w.rgb, stored);
    shares[s] = earned_share(based ? w.table : w.full, stored, meta.domain);
    if (kept[s].ok)
      kept[s].loglik = em_detail::weighted_loglik(b.full_set.grid, em_detail::prepare_slice(b.full_set, s).w, kept[s].gmm);
  });
  for (std::size_t s = 0; s < b.size(); ++s) {
    const SliceWork& w = b.work[s];
    const Fitted& f = kept[s];
    const std::string st = status(b, s);
    part.mixture.l1_rel[first + s] = errors[s].l1_rel;
    part.mixture.defensive[first + s] = shares[s].share;
    part.mixture.loglik[first + s] = f.loglik;
    ReportRow row{w.ref.index, part.mixture.theta_o[first + s], part.mixture.phi_o[first + s], f.gmm.k(), f.iterations,
                  f.loglik, errors[s].l1_rel, seconds / double(b.size()), devices_, st};
    row.rgb_l1_rel = errors[s].rgb_l1_rel;
    row.rgb_negative = errors[s].rgb_negative;
    row.defensive = shares[s].share;
    row.max_weight = shares[s].max_weight;
    part.report.push_back(row);
    part.search.insert(part.search.end(), b.search_rows[s].begin(), b.search_rows[s].end());
    if (st != "ok") log_line("slice " + std::to_string(w.ref.index) + ": " + st);
  }
}

std::size_t batch_size(std::size_t planned, const FitSettings& fit, std::size_t cells_per_slice) {
  if (fit.batch > 0) return std::size_t(fit.batch);
  const std::size_t by_plan = std::clamp<std::size_t>(planned / 32, 4, 64);
  const std::size_t by_cells = cells_per_slice > 0 ? std::max<std::size_t>(kBatchCells / cells_per_slice, 1) : by_plan;
  return std::min(by_plan, by_cells);
}

std::vector<std::vector<SliceRef>> split_batches(const std::vector<SliceRef>& plan, std::size_t batch) {
  std::vector<std::vector<SliceRef>> batches;
  for (std::size_t b0 = 0; b0 < plan.size(); b0 += batch)
    batches.emplace_back(plan.begin() + long(b0), plan.begin() + long(std::min(plan.size(), b0 + batch)));
  return batches;
}

std::string joined_names(const std::vector<Device>& devices) {
  std::string n;
  for (const auto& d : devices) n += (n.empty() ? "" : "+") + d.info().name;
  return n;
}

void hash_weights(Hash64& content, const std::vector<double>& w) { content.update(w.data(), w.size() * sizeof(double)); }

std::string slices_hash(const SliceSource& source, const std::vector<const SliceRef*>& refs) {
  Hash64 content;
  for (const SliceRef* ref : refs) {
    hash_weights(content, source.weights(*ref));
    if (source.meta().rgb) hash_weights(content, source.rgb_weights(*ref));
  }
  return content.hex();
}

SweepResult empty_result(const TableMeta& meta, const FitSettings& fit) {
  SweepResult r;
  r.mixture.domain = meta.domain;
  r.mixture.map = fit_map(fit, meta.domain);
  r.mixture.azimuthal = meta.azimuthal;
  r.mixture.table_source = meta.source;
  r.mixture.fit_settings = fit_settings_json(fit);
  r.mixture.table_theta_o = meta.theta_o;
  r.mixture.table_phi_o = meta.phi_o;
  return r;
}

void append_part(SweepResult& result, const BatchPart& part) {
  for (std::size_t s = 0; s < part.mixture.slices(); ++s) result.mixture.add_slice_from(part.mixture, s);
  result.slice_index.insert(result.slice_index.end(), part.slice_index.begin(), part.slice_index.end());
  result.report.insert(result.report.end(), part.report.begin(), part.report.end());
  result.search.insert(result.search.end(), part.search.begin(), part.search.end());
}

}  // namespace bsdfmix
