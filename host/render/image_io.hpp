// Images of `bsdfmix render`: one float channel (radiance; the tables are luminance),
// row 0 at the top. Written as OpenEXR (R = G = B, half or float) for users and as PFM for
// the figure script (scripts/render_figures.py); both written atomically (temporary name,
// then rename), so a killed render never leaves half an image.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

namespace bsdfmix {
namespace render {

struct Image {
  int width = 0, height = 0;
  std::vector<float> v;  // [height][width]
  Image() = default;
  Image(int w, int h) : width(w), height(h), v(std::size_t(w) * std::size_t(h), 0.f) {}
  float& at(int x, int y) { return v[std::size_t(y) * std::size_t(width) + std::size_t(x)]; }
  float at(int x, int y) const { return v[std::size_t(y) * std::size_t(width) + std::size_t(x)]; }
};

// 32-bit float RGB EXR, R = G = B = the image; throws IoError naming the path.
void write_exr(const std::string& path, const Image& image);
// Reads an EXR written above (or any RGB/Y EXR: luminance 0.2126 R + 0.7152 G + 0.0722 B,
// or Y); throws IoError/InputError naming the path.
Image read_exr(const std::string& path);
// Greyscale PFM ("Pf", little endian, rows bottom to top as the format says) and its
// reader (PF or Pf): host/io/pfm.hpp's codec, with its checks, for an Image.
void write_pfm(const std::string& path, const Image& image);
Image read_pfm_image(const std::string& path);

// Relative mean squared error of `image` against `reference`:
// mean over pixels of (image - reference)^2 / (reference^2 + eps), eps = 1e-2 * mean(reference)^2
// (so that dark pixels do not dominate). InputError when the sizes differ.
double relative_mse(const Image& image, const Image& reference);

}  // namespace render
}  // namespace bsdfmix
