// The stand-in of each slice of a batch: amplitudes fitted on its kept Gaussians
// (fit/amplitudes.hpp), over the slice's cells with each channel's integral kept. The
// luminance's amplitudes give the slice's `scale` (their sum) and its weights (their
// shares), so that the stand-in scale * mixture keeps the table's energy where a Gaussian
// leaks past the theta border; with colour, the channels' give rgb_scale. A slice whose
// colour error stays above `copies_ratio` times its luminance error gets its colour again
// from four copies of each Gaussian (the header's copy_of), kept where that lowers it.
// docs/fitting.md, "Colour and energy" and "Colour copies".
#pragma once

#include <cstddef>
#include <vector>

#include "fit/em.hpp"

namespace bsdfmix {

struct StandIn {
  double scale = 0;
  std::vector<double> weight;  // K, summing to 1
  std::vector<double> rgb;     // 3K, [component][channel]; empty without colour
  // With colour copies: 12K, [component][copy][channel] (rgb then holds their sums per
  // component); empty: the slice's colour is rgb on the components.
  std::vector<double> copies;
};

// A slice gets colour copies when its RGB error exceeds this times its luminance error
// (fit.rgb_copies; 0: every slice with colour, negative: none).
constexpr double kDefaultCopiesRatio = 1.2;

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
std::vector<StandIn> fit_stand_ins(EmEngine& engine, const SliceGrid& grid, const std::vector<StandInSlice>& slices,
                                   double copies_ratio = kDefaultCopiesRatio);

// The colour copies of a mixture's components as a mixture of kCopies x K Gaussians
// (component-major; equal weights), from its parameters rounded to float32 as a mixture
// file stores them, so that the header's copy_of on the stored file gives the same shapes.
Gmm colour_copies(const Gmm& gmm);

}  // namespace bsdfmix
