// Where a fit's time goes: the wall seconds of each phase of a batch's fit, summed over
// the batches this process fitted (docs/studies/em_kernels.md, "Where a fit's time goes").
#pragma once

#include <chrono>
#include <string>

namespace bsdfmix {

struct FitPhases {
  double search = 0;    // the K search (the walk of `search: smem`, or `search: restarts`)
  double final_em = 0;  // the final EM fits of the chosen K (and with smem of its neighbours)
  double beyond = 0;    // with smem, the fits past a stalled walk
  double refine = 0;    // the L1 refinement
  double rest = 0;      // reading the slices, the base, the colour, the earned share, the part

  double total() const { return search + final_em + beyond + refine + rest; }
  FitPhases& operator+=(const FitPhases& o);
  // "search 38%, final EM 21%, ..., the rest 7% of 27.3 s in batches"; "" when nothing
  // was timed (every batch resumed or fitted elsewhere).
  std::string text() const;
};

// Adds the wall seconds from its construction to its destruction to `into`.
class PhaseTimer {
 public:
  explicit PhaseTimer(double& into) : into_(into), start_(std::chrono::steady_clock::now()) {}
  ~PhaseTimer() { into_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count(); }
  PhaseTimer(const PhaseTimer&) = delete;
  PhaseTimer& operator=(const PhaseTimer&) = delete;

 private:
  double& into_;
  std::chrono::steady_clock::time_point start_;
};

}  // namespace bsdfmix
