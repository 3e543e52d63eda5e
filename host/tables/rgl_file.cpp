// The RGL tensor file container: parsing, checks, SHA-256.
#include "tables/rgl_file.hpp"

#include <cstring>
#include <fstream>
#include <iterator>
#include <set>
#include <sstream>

#include "core/error.hpp"
#include "core/file_errors.hpp"

namespace bsdfmix {

std::size_t rgl_dtype_size(std::uint8_t code) {
  switch (code) {
    case 1: case 2: return 1;
    case 3: case 4: case 9: return 2;
    case 5: case 6: case 10: return 4;
    case 7: case 8: case 11: return 8;
    default: return 0;
  }
}

std::string rgl_dtype_name(std::uint8_t code) {
  static constexpr const char* names[] = {"invalid", "uint8", "int8", "uint16", "int16", "uint32",
                                          "int32", "uint64", "int64", "float16", "float32", "float64"};
  return code <= 11 ? names[code] : "dtype code " + std::to_string(code);
}

std::uint64_t RglField::count() const {
  std::uint64_t n = 1;
  for (auto s : shape) n *= s;
  return n;
}

std::uint64_t RglField::bytes() const { return count() * rgl_dtype_size(dtype); }

std::string RglField::shape_text() const {
  std::string s = "[";
  for (std::size_t k = 0; k < shape.size(); ++k) s += (k ? ", " : "") + std::to_string(shape[k]);
  return s + "]";
}

namespace {

// A bounds-checked little-endian cursor over the file bytes.
struct Cursor {
  const std::vector<std::uint8_t>& b;
  std::size_t pos = 0;
  bool has(std::size_t n) const { return pos <= b.size() && b.size() - pos >= n; }
  template <class T>
  T get() {
    T v = 0;
    for (std::size_t k = 0; k < sizeof(T); ++k) v |= T(T(b[pos + k]) << (8 * k));
    pos += sizeof(T);
    return v;
  }
};

constexpr char kMagic[12] = {'t', 'e', 'n', 's', 'o', 'r', '_', 'f', 'i', 'l', 'e', '\0'};
constexpr std::size_t kHeaderBytes = 12 + 2 + 4;
// What to do about a file cut short (an interrupted download).
constexpr char kRedownload[] = "; the file is cut short: download it again from https://rgl.epfl.ch/materials";

}  // namespace

RglFile::RglFile(const std::string& path) : path_(path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) require_readable(path);
  if (!in) throw IoError(path + ": cannot open the RGL file");
  bytes_.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  if (in.bad()) throw IoError(path + ": read error");

  const std::size_t size = bytes_.size();
  const std::size_t m = size < 12 ? size : 12;
  if (m > 0 && std::memcmp(bytes_.data(), kMagic, m) != 0)
    throw InputError(path + ": bad magic, not an RGL tensor file (expected \"tensor_file\\0\")");
  if (size < kHeaderBytes)
    throw InputError(path + ": truncated header (" + std::to_string(size) + " bytes, needs " +
                     std::to_string(kHeaderBytes) + ")" + kRedownload);
  Cursor c{bytes_, 12};
  version_[0] = c.get<std::uint8_t>();
  version_[1] = c.get<std::uint8_t>();
  if (version_[0] != 1 || version_[1] != 0)
    throw InputError(path + ": unsupported tensor file version " + std::to_string(version_[0]) + "." +
                     std::to_string(version_[1]) + " (supported: 1.0)");
  const std::uint32_t n_fields = c.get<std::uint32_t>();
  // Each field header takes at least 2 + 2 + 1 + 8 = 13 bytes.
  if (n_fields == 0 || std::uint64_t(n_fields) * 13 > size - kHeaderBytes)
    throw InputError(path + ": truncated header (" + std::to_string(n_fields) + " fields need at least " +
                     std::to_string(kHeaderBytes + std::uint64_t(n_fields) * 13) + " bytes, file has " +
                     std::to_string(size) + ")" + kRedownload);

  std::set<std::string> names;
  for (std::uint32_t i = 0; i < n_fields; ++i) {
    const std::string which = "field " + std::to_string(i);
    auto need = [&](std::size_t n, const char* what) {
      if (!c.has(n))
        throw InputError(path + ": truncated header of " + which + " (" + what + " at byte " +
                         std::to_string(c.pos) + ", file has " + std::to_string(size) + " bytes)" + kRedownload);
    };
    RglField f;
    need(2, "name length");
    const std::uint16_t name_len = c.get<std::uint16_t>();
    need(name_len, "name");
    f.name.assign(reinterpret_cast<const char*>(bytes_.data() + c.pos), name_len);
    c.pos += name_len;
    const std::string where = path + ": field '" + f.name + "'";
    if (name_len == 0) throw InputError(path + ": " + which + " has an empty name");
    if (!names.insert(f.name).second) throw InputError(where + " appears twice");
    need(2 + 1 + 8, "ndim, dtype, offset");
    const std::uint16_t ndim = c.get<std::uint16_t>();
    f.dtype = c.get<std::uint8_t>();
    f.offset = c.get<std::uint64_t>();
    if (rgl_dtype_size(f.dtype) == 0)
      throw InputError(where + ": unknown dtype code " + std::to_string(f.dtype));
    need(std::size_t(ndim) * 8, "shape");
    for (std::uint16_t d = 0; d < ndim; ++d) f.shape.push_back(c.get<std::uint64_t>());
    // Overflow-safe size of the data (the range check against the file comes after the headers).
    std::uint64_t count = 1;
    for (auto s : f.shape) {
      if (s != 0 && count > (std::uint64_t(1) << 56) / s)
        throw InputError(where + ": shape " + f.shape_text() + " impossibly large");
      count *= s;
    }
    fields_.push_back(std::move(f));
  }
  // Data ranges, once every header has been read (a cut inside the headers is reported as such).
  for (const RglField& f : fields_) {
    const std::uint64_t nbytes = f.bytes();
    if (f.offset > size || nbytes > size - f.offset)
      throw InputError(path + ": field '" + f.name + "': truncated data (" + rgl_dtype_name(f.dtype) + " " +
                       f.shape_text() + " needs bytes " + std::to_string(f.offset) + ".." +
                       std::to_string(f.offset + nbytes) + ", file has " + std::to_string(size) + ")" + kRedownload);
  }
}

const RglField* RglFile::find(const std::string& name) const {
  for (const auto& f : fields_)
    if (f.name == name) return &f;
  return nullptr;
}

const RglField& RglFile::field(const std::string& name) const {
  if (const RglField* f = find(name)) return *f;
  throw InputError(path_ + ": missing field '" + name + "'");
}

std::vector<double> RglFile::as_double(const RglField& f) const {
  const std::uint64_t n = f.count();
  std::vector<double> out(n);
  const std::uint8_t* p = bytes_.data() + f.offset;
  auto load = [&](auto tag) {
    using T = decltype(tag);
    for (std::uint64_t k = 0; k < n; ++k) {
      T v;
      std::memcpy(&v, p + k * sizeof(T), sizeof(T));  // the files and the hosts are little endian
      out[k] = double(v);
    }
  };
  switch (f.dtype) {
    case 1: load(std::uint8_t{}); break;
    case 2: load(std::int8_t{}); break;
    case 3: load(std::uint16_t{}); break;
    case 4: load(std::int16_t{}); break;
    case 5: load(std::uint32_t{}); break;
    case 6: load(std::int32_t{}); break;
    case 7: load(std::uint64_t{}); break;
    case 8: load(std::int64_t{}); break;
    case 10: load(float{}); break;
    case 11: load(double{}); break;
    default:
      throw InputError(path_ + ": field '" + f.name + "': " + rgl_dtype_name(f.dtype) + " not supported");
  }
  return out;
}

std::string RglFile::as_text(const RglField& f) const {
  return std::string(reinterpret_cast<const char*>(bytes_.data() + f.offset), f.bytes());
}

// ---------------------------------------------------------------- SHA-256 (FIPS 180-4)

std::string sha256_hex(const std::vector<std::uint8_t>& data) {
  static const std::uint32_t K[64] = {
      0x428a2f98, 0x71374491, 0xb5c0fbcf, 0xe9b5dba5, 0x3956c25b, 0x59f111f1, 0x923f82a4, 0xab1c5ed5,
      0xd807aa98, 0x12835b01, 0x243185be, 0x550c7dc3, 0x72be5d74, 0x80deb1fe, 0x9bdc06a7, 0xc19bf174,
      0xe49b69c1, 0xefbe4786, 0x0fc19dc6, 0x240ca1cc, 0x2de92c6f, 0x4a7484aa, 0x5cb0a9dc, 0x76f988da,
      0x983e5152, 0xa831c66d, 0xb00327c8, 0xbf597fc7, 0xc6e00bf3, 0xd5a79147, 0x06ca6351, 0x14292967,
      0x27b70a85, 0x2e1b2138, 0x4d2c6dfc, 0x53380d13, 0x650a7354, 0x766a0abb, 0x81c2c92e, 0x92722c85,
      0xa2bfe8a1, 0xa81a664b, 0xc24b8b70, 0xc76c51a3, 0xd192e819, 0xd6990624, 0xf40e3585, 0x106aa070,
      0x19a4c116, 0x1e376c08, 0x2748774c, 0x34b0bcb5, 0x391c0cb3, 0x4ed8aa4a, 0x5b9cca4f, 0x682e6ff3,
      0x748f82ee, 0x78a5636f, 0x84c87814, 0x8cc70208, 0x90befffa, 0xa4506ceb, 0xbef9a3f7, 0xc67178f2};
  std::uint32_t h[8] = {0x6a09e667, 0xbb67ae85, 0x3c6ef372, 0xa54ff53a,
                        0x510e527f, 0x9b05688c, 0x1f83d9ab, 0x5be0cd19};
  auto rotr = [](std::uint32_t x, int n) { return (x >> n) | (x << (32 - n)); };

  std::vector<std::uint8_t> msg(data);
  const std::uint64_t bits = std::uint64_t(data.size()) * 8;
  msg.push_back(0x80);
  while (msg.size() % 64 != 56) msg.push_back(0);
  for (int k = 7; k >= 0; --k) msg.push_back(std::uint8_t(bits >> (8 * k)));

  std::uint32_t w[64];
  for (std::size_t blk = 0; blk < msg.size(); blk += 64) {
    for (int t = 0; t < 16; ++t)
      w[t] = std::uint32_t(msg[blk + 4 * t]) << 24 | std::uint32_t(msg[blk + 4 * t + 1]) << 16 |
             std::uint32_t(msg[blk + 4 * t + 2]) << 8 | std::uint32_t(msg[blk + 4 * t + 3]);
    for (int t = 16; t < 64; ++t) {
      const std::uint32_t s0 = rotr(w[t - 15], 7) ^ rotr(w[t - 15], 18) ^ (w[t - 15] >> 3);
      const std::uint32_t s1 = rotr(w[t - 2], 17) ^ rotr(w[t - 2], 19) ^ (w[t - 2] >> 10);
      w[t] = w[t - 16] + s0 + w[t - 7] + s1;
    }
    std::uint32_t a = h[0], b = h[1], c = h[2], d = h[3], e = h[4], f = h[5], g = h[6], hh = h[7];
    for (int t = 0; t < 64; ++t) {
      const std::uint32_t S1 = rotr(e, 6) ^ rotr(e, 11) ^ rotr(e, 25);
      const std::uint32_t ch = (e & f) ^ (~e & g);
      const std::uint32_t t1 = hh + S1 + ch + K[t] + w[t];
      const std::uint32_t S0 = rotr(a, 2) ^ rotr(a, 13) ^ rotr(a, 22);
      const std::uint32_t mj = (a & b) ^ (a & c) ^ (b & c);
      const std::uint32_t t2 = S0 + mj;
      hh = g; g = f; f = e; e = d + t1; d = c; c = b; b = a; a = t1 + t2;
    }
    h[0] += a; h[1] += b; h[2] += c; h[3] += d; h[4] += e; h[5] += f; h[6] += g; h[7] += hh;
  }
  static constexpr const char* hex = "0123456789abcdef";
  std::string out;
  for (std::uint32_t v : h)
    for (int k = 7; k >= 0; --k) out += hex[(v >> (4 * k)) & 15];
  return out;
}

}  // namespace bsdfmix
