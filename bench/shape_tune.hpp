// `bsdfmix tune`: the candidate kernel shapes of the fitting routines (device/shapes.hpp)
// timed on each selected device by EM fits of known mixtures; the fastest that agrees with
// the default shape is printed as a shapes-file entry and, with an output file, recorded.
#pragma once

#include <string>

#include "fit/em.hpp"

namespace bsdfmix::bench {

struct TuneOptions {
  int k = 16, slices = 32, runs = 3, theta = 90;  // slices of theta x 2 theta cells
  std::string out;                                // shapes file to record in ("" prints only)
  EngineOptions engine;                           // how the timed engines run
};

// Throws DeviceError when no candidate runs on a device.
void tune_shapes(const TuneOptions& o, const std::string& device_selector);

}  // namespace bsdfmix::bench
