// Images of `bsdfmix render`: float32 OpenEXR and greyscale PFM, written atomically.
#include "render/image_io.hpp"

#include <unistd.h>

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfOutputFile.h>

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <vector>

#include "core/atomic_file.hpp"
#include "core/error.hpp"

namespace bsdfmix {
namespace render {

namespace fs = std::filesystem;

namespace {

// Largest side accepted when reading: guards against absurd headers.
constexpr long long kMaxSide = 1 << 20;
constexpr long long kMaxPixels = 1LL << 30;

// Luminance of an RGB pixel; exact when R = G = B (the images written here).
float luminance(float r, float g, float b) {
  if (r == g && g == b) return r;
  return float(0.2126 * double(r) + 0.7152 * double(g) + 0.0722 * double(b));
}

void check_writable_image(const std::string& path, const Image& image) {
  if (image.width <= 0 || image.height <= 0)
    throw InputError(path + ": cannot write an empty image (" + std::to_string(image.width) + "x" +
                     std::to_string(image.height) + ")");
  if (image.v.size() != std::size_t(image.width) * std::size_t(image.height))
    throw InputError(path + ": image holds " + std::to_string(image.v.size()) + " values, not " +
                     std::to_string(image.width) + "x" + std::to_string(image.height));
}

// The temporary name beside `path`; its directory must exist (it is not created).
std::string temp_name(const std::string& path) {
  fs::path dir = fs::path(path).parent_path();
  if (dir.empty()) dir = ".";
  std::error_code ec;
  if (!fs::is_directory(dir, ec))
    throw IoError(path + ": directory " + dir.string() + " does not exist");
  return path + ".partial-" + std::to_string(::getpid());
}

// Removes the temporary unless committed.
struct TempGuard {
  std::string temp;
  bool committed = false;
  ~TempGuard() {
    if (!committed) std::remove(temp.c_str());
  }
};

// fsync of the temporary, rename onto `path`, fsync of the directory.
void commit(TempGuard& guard, const std::string& path) {
  std::FILE* f = std::fopen(guard.temp.c_str(), "rb");
  if (!f) throw IoError(path + ": temporary file vanished before rename: " + std::strerror(errno));
  const int rc = ::fsync(::fileno(f));
  const int err = errno;
  std::fclose(f);
  if (rc != 0) throw IoError(path + ": fsync failed: " + std::strerror(err));
  std::error_code ec;
  fs::rename(guard.temp, path, ec);
  if (ec) throw IoError(path + ": cannot rename temporary file into place: " + ec.message());
  guard.committed = true;
  fsync_directory(path);
}

std::uint32_t float_bits(float f) {
  std::uint32_t u;
  std::memcpy(&u, &f, 4);
  return u;
}

float bits_float(std::uint32_t u) {
  float f;
  std::memcpy(&f, &u, 4);
  return f;
}

}  // namespace

void write_exr(const std::string& path, const Image& image) {
  check_writable_image(path, image);
  TempGuard guard{temp_name(path)};
  std::remove(guard.temp.c_str());
  try {
    Imf::Header header(image.width, image.height);
    header.compression() = Imf::ZIP_COMPRESSION;  // lossless
    for (const char* c : {"R", "G", "B"}) header.channels().insert(c, Imf::Channel(Imf::FLOAT));
    Imf::FrameBuffer fb;
    const char* base = reinterpret_cast<const char*>(image.v.data());
    const std::size_t xs = sizeof(float), ys = sizeof(float) * std::size_t(image.width);
    for (const char* c : {"R", "G", "B"})
      fb.insert(c, Imf::Slice(Imf::FLOAT, const_cast<char*>(base), xs, ys));
    Imf::OutputFile out(guard.temp.c_str(), header);
    out.setFrameBuffer(fb);
    out.writePixels(image.height);
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {
    throw IoError(path + ": cannot write EXR: " + e.what());
  }
  commit(guard, path);
}

Image read_exr(const std::string& path) {
  {
    std::ifstream probe(path, std::ios::binary);
    if (!probe) throw IoError(path + ": cannot open the EXR file: " + std::strerror(errno));
  }
  try {
    Imf::InputFile in(path.c_str());
    const Imath::Box2i dw = in.header().dataWindow();
    const long long w = (long long)dw.max.x - dw.min.x + 1, h = (long long)dw.max.y - dw.min.y + 1;
    if (w <= 0 || h <= 0 || w > kMaxSide || h > kMaxSide || w * h > kMaxPixels)
      throw InputError(path + ": bad EXR data window " + std::to_string(w) + "x" + std::to_string(h));
    const Imf::ChannelList& ch = in.header().channels();
    const bool rgb = ch.findChannel("R") && ch.findChannel("G") && ch.findChannel("B");
    const bool y = ch.findChannel("Y") != nullptr;
    if (!rgb && !y) throw InputError(path + ": EXR has neither R, G, B nor Y channels");
    Image image{int(w), int(h)};
    const std::size_t n = image.v.size();
    Imf::FrameBuffer fb;
    std::vector<float> g, b;
    if (rgb) {
      g.assign(n, 0.f);
      b.assign(n, 0.f);
      fb.insert("R", Imf::Slice::Make(Imf::FLOAT, image.v.data(), dw));
      fb.insert("G", Imf::Slice::Make(Imf::FLOAT, g.data(), dw));
      fb.insert("B", Imf::Slice::Make(Imf::FLOAT, b.data(), dw));
    } else {
      fb.insert("Y", Imf::Slice::Make(Imf::FLOAT, image.v.data(), dw));
    }
    in.setFrameBuffer(fb);
    in.readPixels(dw.min.y, dw.max.y);
    if (rgb)
      for (std::size_t i = 0; i < n; ++i) image.v[i] = luminance(image.v[i], g[i], b[i]);
    return image;
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {
    throw InputError(path + ": not a readable EXR file: " + e.what());
  }
}

void write_pfm(const std::string& path, const Image& image) {
  check_writable_image(path, image);
  TempGuard guard{temp_name(path)};
  {
    std::ofstream f(guard.temp, std::ios::binary | std::ios::trunc);
    if (!f) throw IoError(path + ": cannot create " + guard.temp + ": " + std::strerror(errno));
    f << "Pf\n" << image.width << ' ' << image.height << "\n-1.0\n";
    std::vector<unsigned char> row(std::size_t(image.width) * 4);
    for (int y = image.height - 1; y >= 0; --y) {  // PFM: bottom row first
      for (int x = 0; x < image.width; ++x) {
        const std::uint32_t u = float_bits(image.at(x, y));
        for (int k = 0; k < 4; ++k) row[std::size_t(x) * 4 + std::size_t(k)] = (u >> (8 * k)) & 0xff;
      }
      f.write(reinterpret_cast<const char*>(row.data()), std::streamsize(row.size()));
    }
    f.flush();
    if (!f) throw IoError(path + ": write failed (disk full?)");
  }
  commit(guard, path);
}

Image read_pfm_image(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw IoError(path + ": cannot open the PFM file: " + std::strerror(errno));
  // Header: three whitespace-separated tokens after the magic, then one whitespace byte.
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
  int channels = 0;
  if (magic == "Pf")
    channels = 1;
  else if (magic == "PF")
    channels = 3;
  else
    throw InputError(path + ": not a PFM file (magic is not Pf or PF)");
  auto integer = [&](const char* what) {
    const std::string t = token(what);
    long long v = 0;
    for (char c : t) {
      if (c < '0' || c > '9' || v > kMaxSide)
        throw InputError(path + ": bad PFM " + what + " '" + t + "'");
      v = v * 10 + (c - '0');
    }
    if (v <= 0 || v > kMaxSide) throw InputError(path + ": bad PFM " + what + " '" + t + "'");
    return v;
  };
  const long long w = integer("width"), h = integer("height");
  if (w * h > kMaxPixels)
    throw InputError(path + ": PFM too large (" + std::to_string(w) + "x" + std::to_string(h) + ")");
  const std::string scale_s = token("scale");
  char* end = nullptr;
  const double scale = std::strtod(scale_s.c_str(), &end);
  if (end == scale_s.c_str() || *end != '\0' || scale == 0.0 || !std::isfinite(scale))
    throw InputError(path + ": bad PFM scale '" + scale_s + "'");
  const bool little = scale < 0;

  Image image{int(w), int(h)};
  const std::size_t row_bytes = std::size_t(w) * 4 * std::size_t(channels);
  std::vector<unsigned char> row(row_bytes);
  for (long long y = h - 1; y >= 0; --y) {
    f.read(reinterpret_cast<char*>(row.data()), std::streamsize(row_bytes));
    if (f.gcount() != std::streamsize(row_bytes))
      throw InputError(path + ": truncated PFM (" + std::to_string(w) + "x" + std::to_string(h) +
                       " pixels expected)");
    for (long long x = 0; x < w; ++x) {
      float c[3] = {0, 0, 0};
      for (int k = 0; k < channels; ++k) {
        const unsigned char* p = row.data() + (std::size_t(x) * std::size_t(channels) + std::size_t(k)) * 4;
        std::uint32_t u = 0;
        for (int b = 0; b < 4; ++b) u |= std::uint32_t(p[little ? b : 3 - b]) << (8 * b);
        c[k] = bits_float(u);
      }
      image.at(int(x), int(y)) = channels == 1 ? c[0] : luminance(c[0], c[1], c[2]);
    }
  }
  if (f.peek() != std::char_traits<char>::eof())
    throw InputError(path + ": trailing bytes after the PFM pixels");
  return image;
}

double relative_mse(const Image& image, const Image& reference) {
  if (image.width != reference.width || image.height != reference.height)
    throw InputError("relative_mse: image is " + std::to_string(image.width) + "x" +
                     std::to_string(image.height) + " but the reference is " +
                     std::to_string(reference.width) + "x" + std::to_string(reference.height));
  const std::size_t n = reference.v.size();
  if (n == 0 || image.v.size() != n) throw InputError("relative_mse: empty or inconsistent image");
  double mean = 0;
  for (float r : reference.v) mean += double(r);
  mean /= double(n);
  const double eps = 1e-2 * mean * mean;
  double sum = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const double r = reference.v[i], d = double(image.v[i]) - r;
    if (d == 0) continue;  // also when r = eps = 0
    sum += d * d / (r * r + eps);
  }
  return sum / double(n);
}

}  // namespace render
}  // namespace bsdfmix
