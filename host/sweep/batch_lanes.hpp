// Batches fitted side by side in one process. A batch's fit alternates between the
// device (EM, the L1 kernels) and host steps (starts, split-and-merge scores, exact L1
// errors); with one batch in flight the device waits through the host steps and the
// cores through the device's short calls. Each lane fits its own batches with its own
// engine on the same devices, so while one lane is on the host another keeps the device
// busy. A batch's fit depends only on its slices and the settings: the lanes change
// when a batch finishes, never what it holds.
#pragma once

#include <cstddef>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "device/device.hpp"
#include "fit/em.hpp"
#include "sweep/checkpoint.hpp"
#include "sweep/fit_settings.hpp"
#include "sweep/slice_plan.hpp"
#include "sweep/slice_source.hpp"

namespace bsdfmix {

class BatchLanes {
 public:
  // `source`, `fit` and `devices` must outlive the lanes. `lanes` is lowered to 1 where a
  // device takes one host thread at a time (DeviceInfo::concurrent_host_threads; said
  // on the log).
  BatchLanes(const SliceSource& source, const FitSettings& fit, const std::vector<Device>& devices,
             const EngineOptions& engine, const std::string& device_names, unsigned lanes);
  ~BatchLanes();

  // Fits every batch, `lanes` at a time, and calls `commit` once per batch on the
  // calling thread, in the order they finish. With one lane (or one batch) the batches
  // are fitted on the calling thread, in order. The table's reads and `commit` never run
  // at the same time (HDF5 is not thread-safe). The first error stops the lanes and
  // is thrown here once they have stopped; what was committed stays committed.
  void run(const std::vector<std::vector<SliceRef>>& batches, const std::function<void(BatchPart&&)>& commit);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace bsdfmix
