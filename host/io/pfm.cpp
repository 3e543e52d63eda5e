// PFM images: the strict reader and the atomic writer.
#include "io/pfm.hpp"

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "core/atomic_file.hpp"
#include "core/color.hpp"
#include "core/error.hpp"

namespace bsdfmix {

namespace {

constexpr long long kMaxSide = 65536;
constexpr long long kMaxPixels = 1LL << 30;

float bits_float(std::uint32_t u) {
  float f;
  std::memcpy(&f, &u, 4);
  return f;
}

std::uint32_t float_bits(float f) {
  std::uint32_t u;
  std::memcpy(&u, &f, 4);
  return u;
}

}  // namespace

float luminance(float r, float g, float b) { return float(rec709_luminance(r, g, b)); }

PfmImage read_pfm(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw IoError(path + ": cannot open the PFM file: " + std::strerror(errno));
  // Header: the magic and three tokens, separated by whitespace; one whitespace byte ends it.
  auto token = [&](const char* what) {
    std::string t;
    int c = f.get();
    while (c != EOF && std::isspace(c)) c = f.get();
    while (c != EOF && !std::isspace(c) && t.size() < 64) {
      t.push_back(char(c));
      c = f.get();
    }
    if (t.empty() || c == EOF || !std::isspace(c))
      throw InputError(path + ": not a PFM file (bad or truncated header at the " + what + ")");
    return t;
  };
  const std::string magic = token("magic");
  if (magic != "Pf" && magic != "PF")
    throw InputError(path + ": not a PFM file (header '" + magic.substr(0, 8) + "', expected PF or Pf)");
  const int channels = magic == "PF" ? 3 : 1;
  auto side = [&](const char* what) {
    const std::string t = token(what);
    long long v = 0;
    for (char c : t) {
      if (c < '0' || c > '9' || v > kMaxSide) throw InputError(path + ": bad PFM " + what + " '" + t + "'");
      v = v * 10 + (c - '0');
    }
    if (v < 1 || v > kMaxSide)
      throw InputError(path + ": PFM " + what + " " + t + " out of range (1 to " + std::to_string(kMaxSide) + ")");
    return v;
  };
  const long long w = side("width"), h = side("height");
  if (w * h > kMaxPixels)
    throw InputError(path + ": PFM too large (" + std::to_string(w) + " x " + std::to_string(h) + " pixels)");
  const std::string scale_s = token("scale");
  char* end = nullptr;
  const double scale = std::strtod(scale_s.c_str(), &end);
  if (end == scale_s.c_str() || *end != '\0' || scale == 0.0 || !std::isfinite(scale))
    throw InputError(path + ": bad PFM scale '" + scale_s + "' (must be a finite non-zero number)");
  const bool little = scale < 0;

  PfmImage img;
  img.width = int(w);
  img.height = int(h);
  img.luminance.resize(std::size_t(w) * std::size_t(h));
  img.rgb.resize(3 * img.luminance.size());
  const std::size_t row_bytes = std::size_t(w) * 4 * std::size_t(channels);
  std::vector<unsigned char> row(row_bytes);
  for (long long y = h - 1; y >= 0; --y) {  // the file's first row is the image's last
    f.read(reinterpret_cast<char*>(row.data()), std::streamsize(row_bytes));
    if (f.gcount() != std::streamsize(row_bytes))
      throw InputError(path + ": truncated PFM (" + std::to_string(w) + " x " + std::to_string(h) +
                       " pixels expected)");
    for (long long x = 0; x < w; ++x) {
      float c[3] = {0, 0, 0};
      for (int k = 0; k < channels; ++k) {
        const unsigned char* p = row.data() + (std::size_t(x) * std::size_t(channels) + std::size_t(k)) * 4;
        std::uint32_t u = 0;
        for (int b = 0; b < 4; ++b) u |= std::uint32_t(p[little ? b : 3 - b]) << (8 * b);
        c[k] = bits_float(u);
        if (!std::isfinite(c[k]) || c[k] < 0)
          throw InputError(path + ": pixel (" + std::to_string(x) + ", " + std::to_string(y) +
                           ") is negative or not finite");
      }
      const std::size_t at = std::size_t(y) * std::size_t(w) + std::size_t(x);
      img.luminance[at] = channels == 1 ? c[0] : luminance(c[0], c[1], c[2]);
      for (int k = 0; k < 3; ++k) img.rgb[3 * at + std::size_t(k)] = c[channels == 1 ? 0 : k];
    }
  }
  if (f.peek() != std::char_traits<char>::eof()) throw InputError(path + ": trailing bytes after the PFM pixels");
  return img;
}

void write_pfm(const std::string& path, int width, int height, const std::vector<float>& values, int channels) {
  if (channels != 1 && channels != 3)
    throw InputError(path + ": a PFM holds 1 or 3 channels, not " + std::to_string(channels));
  if (width <= 0 || height <= 0)
    throw InputError(path + ": cannot write an empty image (" + std::to_string(width) + "x" +
                     std::to_string(height) + ")");
  const std::size_t nc = std::size_t(channels);
  if (values.size() != std::size_t(width) * std::size_t(height) * nc)
    throw InputError(path + ": image holds " + std::to_string(values.size()) + " values, not " +
                     std::to_string(width) + "x" + std::to_string(height) + (channels == 3 ? "x3" : ""));
  std::filesystem::path dir = std::filesystem::path(path).parent_path();
  if (dir.empty()) dir = ".";
  std::error_code ec;
  if (!std::filesystem::is_directory(dir, ec))
    throw IoError(path + ": directory " + dir.string() + " does not exist");
  AtomicOutput out(path);
  {
    std::ofstream f(out.temp_path(), std::ios::binary | std::ios::trunc);
    if (!f) throw IoError(path + ": cannot create " + out.temp_path() + ": " + std::strerror(errno));
    f << (channels == 3 ? "PF\n" : "Pf\n") << width << ' ' << height << "\n-1.0\n";
    const std::size_t per_row = std::size_t(width) * nc;
    std::vector<unsigned char> row(per_row * 4);
    for (int y = height - 1; y >= 0; --y) {  // bottom row first
      for (std::size_t i = 0; i < per_row; ++i) {
        const std::uint32_t u = float_bits(values[std::size_t(y) * per_row + i]);
        for (int k = 0; k < 4; ++k) row[i * 4 + std::size_t(k)] = (u >> (8 * k)) & 0xff;
      }
      f.write(reinterpret_cast<const char*>(row.data()), std::streamsize(row.size()));
    }
    f.flush();
    if (!f) throw IoError(path + ": write failed (disk full?)");
  }
  out.commit();
}

}  // namespace bsdfmix
