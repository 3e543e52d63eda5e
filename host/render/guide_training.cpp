// The guided estimators' training schedule.
#include "render/guide_training.hpp"

#include "core/format.hpp"
#include "core/progress.hpp"

namespace bsdfmix {
namespace render {

GuideTrainer::GuideTrainer(const SceneView& base, const GuideSetup& setup, std::string what)
    : view_(base), setup_(setup), what_(std::move(what)) {
  view_.guide = &field_;
  view_.guide_depth = setup_.depth;
  rows_.resize(std::size_t(view_.height));
  view_.train = setup_.iterations > 0 ? &rows_ : nullptr;
}

void GuideTrainer::after_pass(int done) {
  if (!view_.train || done < next_end_) return;
  // the iteration's samples, row by row: the same order whatever the threads
  std::size_t n = 0;
  for (const auto& r : rows_) n += r.size();
  std::vector<guide::Sample> samples;
  samples.reserve(n);
  for (auto& r : rows_) {
    samples.insert(samples.end(), r.begin(), r.end());
    r.clear();
  }
  ++iteration_;
  field_.learn(samples, setup_.field, setup_.devices,
               what_ + ": learn the radiance (iteration " + std::to_string(iteration_) + " of " +
                   std::to_string(setup_.iterations) + ")",
               setup_.engine);
  log_line("render: " + what_ + ": iteration " + std::to_string(iteration_) + ": " + std::to_string(n) +
           " samples, " + std::to_string(field_.leaves()) + " leaves, " + std::to_string(field_.fitted()) +
           " fitted, " + std::to_string(field_.guiding()) + " guiding, mean K " + format_number(field_.mean_k(), "%.2f") + ", " +
           format_number(field_.fit_seconds(), "%.2f") + " s");
  next_end_ = 2 * next_end_ + 1;  // iterations of 1, 2, 4, ... passes
  if (iteration_ >= setup_.iterations) {
    view_.train = nullptr;
    rows_.clear();
    rows_.shrink_to_fit();
  }
}

}  // namespace render
}  // namespace bsdfmix
