// Luminance of linear RGB in Rec. 709 / sRGB primaries, the one definition: the fiber and
// RGL tables' `values` beside their `rgb` (docs/formats.md, "Table file"), the images.
#pragma once

namespace bsdfmix {

// Y = 0.2126 R + 0.7152 G + 0.0722 B (the weights sum to 1), in double; exactly R when
// R = G = B, so that a grey keeps its number.
inline double rec709_luminance(double r, double g, double b) {
  if (r == g && g == b) return r;
  return 0.2126 * r + 0.7152 * g + 0.0722 * b;
}

}  // namespace bsdfmix
