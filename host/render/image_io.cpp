// Images of `bsdfmix render`: float32 OpenEXR, written atomically, and PFM (host/io/pfm.cpp).
#include "render/image_io.hpp"

#include <unistd.h>

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfOutputFile.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <utility>
#include <vector>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "io/pfm.hpp"

namespace bsdfmix {
namespace render {

namespace fs = std::filesystem;

namespace {

// Largest side accepted when reading: guards against absurd headers.
constexpr long long kMaxSide = 1 << 20;
constexpr long long kMaxPixels = 1LL << 30;

void check_writable_image(const std::string& path, const Image& image) {
  if (image.width <= 0 || image.height <= 0)
    throw InputError(path + ": cannot write an empty image (" + std::to_string(image.width) + "x" +
                     std::to_string(image.height) + ")");
  if (image.v.size() != 3 * std::size_t(image.width) * std::size_t(image.height))
    throw InputError(path + ": image holds " + std::to_string(image.v.size()) + " values, not " +
                     std::to_string(image.width) + "x" + std::to_string(image.height) + "x3");
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
    const std::size_t xs = 3 * sizeof(float), ys = 3 * sizeof(float) * std::size_t(image.width);
    const char* names[3] = {"R", "G", "B"};
    for (int c = 0; c < 3; ++c)
      fb.insert(names[c], Imf::Slice(Imf::FLOAT, const_cast<char*>(base) + c * sizeof(float), xs, ys));
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
    const std::size_t n = std::size_t(w) * std::size_t(h);
    std::vector<float> plane[3];
    Imf::FrameBuffer fb;
    const char* names[3] = {"R", "G", "B"};
    for (int c = 0; c < (rgb ? 3 : 1); ++c) {
      plane[c].assign(n, 0.f);
      fb.insert(rgb ? names[c] : "Y", Imf::Slice::Make(Imf::FLOAT, plane[c].data(), dw));
    }
    in.setFrameBuffer(fb);
    in.readPixels(dw.min.y, dw.max.y);
    for (std::size_t i = 0; i < n; ++i)
      for (int c = 0; c < 3; ++c) image.v[3 * i + std::size_t(c)] = plane[rgb ? c : 0][i];
    return image;
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {
    throw InputError(path + ": not a readable EXR file: " + e.what());
  }
}

void write_pfm(const std::string& path, const Image& image) {
  check_writable_image(path, image);
  bsdfmix::write_pfm(path, image.width, image.height, image.v, 3);
}

Image read_pfm_image(const std::string& path) {
  PfmImage p = read_pfm(path);
  Image image;
  image.width = p.width;
  image.height = p.height;
  image.v = std::move(p.rgb);
  return image;
}

double relative_mse(const Image& image, const Image& reference, const std::vector<std::uint8_t>* mask) {
  if (image.width != reference.width || image.height != reference.height)
    throw InputError("relative_mse: image is " + std::to_string(image.width) + "x" +
                     std::to_string(image.height) + " but the reference is " +
                     std::to_string(reference.width) + "x" + std::to_string(reference.height));
  const std::size_t n = reference.v.size();
  if (n == 0 || image.v.size() != n) throw InputError("relative_mse: empty or inconsistent image");
  if (mask && mask->size() != n / 3)
    throw InputError("relative_mse: the mask has " + std::to_string(mask->size()) + " pixels but the image " +
                     std::to_string(n / 3));
  double mean = 0;
  for (float r : reference.v) mean += double(r);
  mean /= double(n);
  const double eps = 1e-2 * mean * mean;
  double sum = 0;
  std::size_t counted = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (mask && !(*mask)[i / 3]) continue;
    ++counted;
    const double r = reference.v[i], d = double(image.v[i]) - r;
    if (d == 0) continue;  // also when r = eps = 0
    sum += d * d / (r * r + eps);
  }
  return counted ? sum / double(counted) : -1.0;
}

}  // namespace render
}  // namespace bsdfmix
