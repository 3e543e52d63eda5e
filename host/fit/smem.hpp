// Split-and-merge moves on fitted slice mixtures (after Ueda et al. 2000, "SMEM"):
// which component fits its cells worst, which pairs share their cells, and the
// mixtures that split, merge or both. The host picks the moves; the EM that
// follows each move runs as an ordinary batched EmTask with an explicit start.
// docs/studies/search.md, "The walk, step by step", describes how the search uses them.
#pragma once

#include <functional>
#include <utility>
#include <vector>

#include "fit/em.hpp"
#include "fit/gmm.hpp"
#include "fit/slices.hpp"

namespace bsdfmix {

struct ComponentScores {
  // Per component: the local Kullback-Leibler divergence between the cells' weights
  // as the component claims them (w_i r_ik, normalized) and the component's own
  // density over the cells (normalized over the grid, so a component cut by the
  // theta border is compared with its in-domain part). High: the component covers
  // something that is not one Gaussian.
  std::vector<double> split;
  // Per component: the covariance axis to split along, 0 the major, 1 the minor: the
  // one along which the claimed weights are flatter than a Gaussian (the lower
  // standardized fourth moment: two lobes side by side along the minor axis of their
  // one-component fit are only seen there).
  std::vector<int> axis;
  // Pairs (i < j) by decreasing responsibility overlap
  //   sum_c w_c r_ci r_cj / sqrt(sum_c w_c r_ci^2 * sum_c w_c r_cj^2),
  // at most the number asked for. High: two components share one lobe.
  std::vector<std::pair<int, int>> merge;
};

// Scores of `gmm` against the slice weights `w` (any positive scale) on `grid`.
ComponentScores score_components(const SliceGrid& grid, const std::vector<double>& w, const Gmm& gmm,
                                 std::size_t max_pairs);

// `gmm` with component j replaced by two halves along a covariance axis (0 the major,
// 1 the minor) of eigenvalue lambda: means at +-sqrt(lambda)/2, weights halved, the
// covariance shrunk along that axis so the pair keeps the component's mean and
// covariance (eigenvalues raised to `floor`). The new half is appended as component k.
Gmm split_component(const Gmm& gmm, int j, double floor, int axis = 0);

// `gmm` with components i and j replaced by their moment-matched merge (at index
// min(i, j); the other removed).
Gmm merge_components(const Gmm& gmm, int i, int j);

// `gmm` grown to k_new components by splitting, one after the other, the component
// with the highest split score along its axis (each half inherits half the score of its
// parent and splits along its major axis).
Gmm grow_mixture(const Gmm& gmm, const ComponentScores& scores, int k_new, double floor);

// `gmm` grown to k_new components by components seeded where the slice holds most that
// the mixture does not: each new component sits at the cell of the largest residual
// w_i - W m_i (m_i the mixture's cell mass, W = sum w), with the mean and covariance
// (eigenvalues raised to `floor`) of the positive residual in the 5 x 5 cells around it
// and that residual's share of W as its weight (the others scaled to keep the sum 1);
// that window is then spent and the next component seeded. A sharp peak that EM's
// growth by splitting never reaches gets a component of its own this way.
Gmm seed_at_residual(const SliceGrid& grid, const std::vector<double>& w, const Gmm& gmm, int k_new, double floor);

// Up to `count` split-and-merge candidates of the same K: the pairs in `scores.merge`
// order merged, each with the worst-scoring other component split. Needs K >= 3.
std::vector<Gmm> smem_candidates(const Gmm& gmm, const ComponentScores& scores, int count, double floor);

// How hard split_merge_fit tries.
struct SmemSettings {
  int rounds = 1;      // rounds of moves after the first EM (each one batch of EM fits)
  int candidates = 2;  // moves tried per task and round
};

// A batch EM fit: EmEngine::fit or em_fit_reference.
using EmFitter = std::function<std::vector<EmResult>(const SliceSet&, const std::vector<EmTask>&)>;

// Fits every task by EM (its start as the task says), then runs split-and-merge
// rounds: each round tries up to `candidates` moves per task (K >= 3), all tasks'
// moves in one call of `fitter` (EM from each move with the task's settings, one
// restart), and keeps the best move of a task when its weighted log-likelihood
// beats the task's current fit. The result of a task is never worse (in log-
// likelihood) than the first EM. `accepted`, when given, receives the number of
// moves kept per task.
std::vector<EmResult> split_merge_fit(const EmFitter& fitter, const SliceSet& set, const std::vector<EmTask>& tasks,
                                      const SmemSettings& settings, std::vector<int>* accepted = nullptr);

}  // namespace bsdfmix
