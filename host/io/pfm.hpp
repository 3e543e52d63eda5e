// PFM images (Portable Float Map: "Pf" grey or "PF" RGB, either byte order), the one codec
// of the convergence scenes' environment maps and the renderer's images. In memory the
// luminance, and R, G, B (of a grey file: the value three times), row 0 at the top; the
// file stores the rows bottom to top.
#pragma once

#include <string>
#include <vector>

namespace bsdfmix {

struct PfmImage {
  int width = 0, height = 0;
  std::vector<float> luminance;  // [height][width], row 0 at the top
  std::vector<float> rgb;        // [height][width][3]
};

// Luminance of an RGB value, 0.2126 R + 0.7152 G + 0.0722 B (in double, rec709_luminance of
// core/color.hpp); exactly R when R = G = B.
float luminance(float r, float g, float b);

// Reads `path`, strictly: the magic Pf or PF; width and height decimal digits in
// 1 .. 65536, at most 2^30 pixels; a finite non-zero scale (negative: little endian);
// one whitespace byte, then exactly the pixels' bytes, no fewer and no more; every value
// finite and non-negative. IoError when the file cannot be opened, InputError otherwise;
// each error one line naming the file and what is wrong.
PfmImage read_pfm(const std::string& path);

// Writes a little-endian PFM of `width` x `height` pixels (row 0 at the top) of `channels`
// values each, interleaved: 1 writes grey ("Pf"), 3 writes RGB ("PF"); scale -1.0; atomically: under a temporary name beside `path`, then renamed, so a killed
// writer never leaves half an image. The directory must exist. InputError for an empty
// image or one whose value count is not width x height x channels; IoError naming the path
// when it cannot be written.
void write_pfm(const std::string& path, int width, int height, const std::vector<float>& values, int channels = 1);
inline void write_pfm(const std::string& path, const PfmImage& image) {
  write_pfm(path, image.width, image.height, image.luminance);
}

}  // namespace bsdfmix
