// The stand-in of each slice of a batch: amplitudes fitted on its kept Gaussians
// (fit/amplitudes.hpp), over the slice's cells with each channel's integral kept. The
// luminance's amplitudes give the slice's `scale` (their sum) and its weights (their
// shares), so that the stand-in scale * mixture keeps the table's energy where a Gaussian
// leaks past the theta border; with colour, the channels' give rgb_scale. docs/fitting.md,
// "Colour and energy".
#pragma once

#include <cstddef>
#include <vector>

#include "fit/em.hpp"

namespace bsdfmix {

struct StandIn {
  double scale = 0;
  std::vector<double> weight;  // K, summing to 1
  std::vector<double> rgb;     // 3K, [component][channel]; empty without colour
};

// One slice: its Gaussians, its luminance integrand weights and, with colour, its R, G, B
// integrand weights (channel-major; SliceSource::rgb_weights).
struct StandInSlice {
  const Gmm* gmm = nullptr;
  const std::vector<double>* luminance = nullptr;
  const std::vector<double>* rgb = nullptr;  // null without colour
};

// The stand-ins of a batch's slices on `grid`, every slice's amplitudes fitted together
// on the engine's devices. A slice whose luminance is zero keeps scale 0 and its weights
// (and rgb_scale 0); every slice of a call has colour, or none.
std::vector<StandIn> fit_stand_ins(EmEngine& engine, const SliceGrid& grid, const std::vector<StandInSlice>& slices);

}  // namespace bsdfmix
