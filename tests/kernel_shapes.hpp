// The kernel shapes the fitting programs compile for (device/shapes.hpp make_shape: vec 16,
// 8 or 4 with one work-item per group, or scalar work-items in groups of 1 to 512), as the
// kernel-against-reference tests run them: every vector width, and scalar work-items
// alone, in the GPU table's groups of 64 and in the largest group. The CPU table's vec 16
// runs in both precisions; each other shape in one of them.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "device/device.hpp"
#include "device/shapes.hpp"
#include "fit/em.hpp"

namespace bsdfmix::test {

struct ShapeRun {
  EmPrecision precision;
  KernelShape shape;
  std::string label() const { return shape.label() + ", precision " + precision_name(precision); }
  bool gpu_layout() const { return shape.vec == 1; }
};

inline std::vector<ShapeRun> shape_runs() {
  return {{EmPrecision::Auto, make_shape(16, 1)}, {EmPrecision::Fp32, make_shape(16, 1)},
          {EmPrecision::Fp32, make_shape(8, 1)},  {EmPrecision::Auto, make_shape(4, 1)},
          {EmPrecision::Auto, make_shape(1, 1)},  {EmPrecision::Fp32, make_shape(1, 64)},
          {EmPrecision::Fp32, make_shape(1, 512)}};
}

// An engine on the first device that runs `run`'s shape and precision.
inline std::unique_ptr<EmEngine> shape_engine(const ShapeRun& run) {
  auto e = std::make_unique<EmEngine>(select_devices(""), 1, run.precision);
  e->set_shape(run.shape);
  return e;
}

}  // namespace bsdfmix::test
