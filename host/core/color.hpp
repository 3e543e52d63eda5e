// Linear RGB (Rec. 709 / sRGB primaries) as the renderer carries it along paths, and its
// luminance Y, the one definition: the fiber and RGL tables' `values` beside their `rgb`
// (docs/formats.md, "Table file"), the images.
#pragma once

#include <algorithm>

namespace bsdfmix {

// The luminance weights of Rec. 709: Y = 0.2126 R + 0.7152 G + 0.0722 B.
constexpr double kLumaR = 0.2126, kLumaG = 0.7152, kLumaB = 0.0722;

// Y of (r, g, b) in double (the weights sum to 1); exactly r when r = g = b, so that a grey
// keeps its number.
inline double rec709_luminance(double r, double g, double b) {
  if (r == g && g == b) return r;
  return kLumaR * r + kLumaG * g + kLumaB * b;
}

struct Rgb {
  double c[3] = {0, 0, 0};
  Rgb() = default;
  explicit Rgb(double grey) : c{grey, grey, grey} {}
  Rgb(double r, double g, double b) : c{r, g, b} {}
  double& operator[](int i) { return c[i]; }
  double operator[](int i) const { return c[i]; }
  // The largest channel: what decides "is there anything" and Russian roulette, so that
  // a grey value behaves exactly as the plain number it stands for.
  double max() const { return std::max(c[0], std::max(c[1], c[2])); }
  double luminance() const { return rec709_luminance(c[0], c[1], c[2]); }
  Rgb& operator+=(const Rgb& o) {
    for (int i = 0; i < 3; ++i) c[i] += o.c[i];
    return *this;
  }
  Rgb& operator*=(const Rgb& o) {
    for (int i = 0; i < 3; ++i) c[i] *= o.c[i];
    return *this;
  }
  Rgb& operator*=(double s) {
    for (double& x : c) x *= s;
    return *this;
  }
  Rgb& operator/=(double s) {
    for (double& x : c) x /= s;
    return *this;
  }
};

inline Rgb operator*(Rgb a, const Rgb& b) { return a *= b; }
inline Rgb operator*(Rgb a, double s) { return a *= s; }
inline Rgb operator/(Rgb a, double s) { return a /= s; }

}  // namespace bsdfmix
