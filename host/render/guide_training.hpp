// The guided estimators' learning (docs/render.md, "Guided paths"): the first passes of a
// guided render train the radiance field in iterations of 1, 2, 4, ... passes, each
// iteration's samples learning the field the next one samples with (Mueller et al.
// 2017's schedule); every pass, training ones included, is an unbiased image and counts
// in the render's samples and time.
#pragma once

#include <string>
#include <vector>

#include "device/device.hpp"
#include "fit/em.hpp"
#include "guide/radiance_field.hpp"
#include "render/integrator.hpp"

namespace bsdfmix {
namespace render {

// What a guided render learns with: the field's settings (its leaves' fit and the largest
// share of guided directions among them), the training iterations, the path vertices
// guided, the devices that fit and how their engine runs.
struct GuideSetup {
  guide::FieldSettings field;
  int iterations = 4, depth = 1;
  std::vector<Device> devices;
  EngineOptions engine;
};

class GuideTrainer {
 public:
  // `base` is copied, `setup` must outlive the trainer; with 0 iterations the field stays
  // empty and the guided estimators sample as mis_light_gmm.
  GuideTrainer(const SceneView& base, const GuideSetup& setup, std::string what);
  GuideTrainer(const GuideTrainer&) = delete;
  GuideTrainer& operator=(const GuideTrainer&) = delete;

  // The view the passes render with: its guide and training sink are this trainer's.
  const SceneView& view() const { return view_; }
  // After pass `done` (1-based): at the end of an iteration, learns the field from its
  // samples; after the last one, stops collecting.
  void after_pass(int done);
  const guide::RadianceField& field() const { return field_; }

 private:
  SceneView view_;
  const GuideSetup& setup_;
  int iteration_ = 0, next_end_ = 1;
  std::string what_;
  guide::RadianceField field_;
  std::vector<std::vector<guide::Sample>> rows_;
};

}  // namespace render
}  // namespace bsdfmix
