// Images of `bsdfmix render`: linear RGB radiance (Rec. 709 primaries; a table without
// color gives R = G = B), row 0 at the top. Written as float32 OpenEXR (R, G, B) for users
// and as RGB PFM for the figure script (scripts/render_figures.py); both written atomically
// (temporary name, then rename), so a killed render never leaves half an image.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace bsdfmix {
namespace render {

struct Image {
  int width = 0, height = 0;
  std::vector<float> v;  // [height][width][3]: R, G, B
  Image() = default;
  Image(int w, int h) : width(w), height(h), v(3 * std::size_t(w) * std::size_t(h), 0.f) {}
  std::size_t index(int x, int y, int c) const {
    return 3 * (std::size_t(y) * std::size_t(width) + std::size_t(x)) + std::size_t(c);
  }
  float& at(int x, int y, int c) { return v[index(x, y, c)]; }
  float at(int x, int y, int c) const { return v[index(x, y, c)]; }
  // Every channel of pixel (x, y) set to `grey`.
  void set_grey(int x, int y, float grey) {
    for (int c = 0; c < 3; ++c) at(x, y, c) = grey;
  }
};

// 32-bit float RGB EXR; throws IoError naming the path.
void write_exr(const std::string& path, const Image& image);
// Reads an EXR written above (or any RGB EXR, or a Y one as grey); throws IoError or
// InputError naming the path.
Image read_exr(const std::string& path);
// RGB PFM ("PF", little endian, rows bottom to top as the format says) and its reader (a
// grey "Pf" reads as R = G = B): host/io/pfm.hpp's codec, with its checks, for an Image.
void write_pfm(const std::string& path, const Image& image);
Image read_pfm_image(const std::string& path);

// Relative mean squared error of `image` against `reference`, averaged over the channels:
// mean over pixels and channels of (image - reference)^2 / (reference^2 + eps),
// eps = 1e-2 * mean(reference)^2 over every value (so that dark pixels do not dominate).
// With `mask` (one byte per pixel, row-major, non-zero: counted), the mean is over the
// masked pixels only, eps still from every value; -1 when the mask holds no pixel.
// InputError when the sizes differ.
double relative_mse(const Image& image, const Image& reference, const std::vector<std::uint8_t>* mask = nullptr);

}  // namespace render
}  // namespace bsdfmix
