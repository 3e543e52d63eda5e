// A 64-bit content hash: 8-byte words folded through a multiply-xorshift mix.
#include "core/hash.hpp"

#include <cstdio>
#include <cstring>
#include <fstream>
#include <vector>

#include "core/error.hpp"

namespace bsdfmix {

namespace {

std::uint64_t mix(std::uint64_t x) {
  x ^= x >> 32;
  x *= 0xd6e8feb86659fd93ull;
  x ^= x >> 32;
  x *= 0xd6e8feb86659fd93ull;
  return x ^ (x >> 32);
}

}  // namespace

// hash_file feeds a file to the hash kFileChunk bytes at a time, then what is left (0 to
// kFileChunk - 1 bytes); the value depends on that split, which hash_file_bytes repeats.
constexpr std::size_t kFileChunk = 1 << 20;

Hash64& Hash64::update(const void* data, std::size_t bytes) {
  const auto* p = static_cast<const unsigned char*>(data);
  std::size_t i = 0;
  for (; i + 8 <= bytes; i += 8) {
    std::uint64_t w;
    std::memcpy(&w, p + i, 8);
    h_ = (h_ ^ mix(w + 0x9e3779b97f4a7c15ull)) * 0x9fb21c651e98df25ull;
    h_ = (h_ << 29) | (h_ >> 35);
  }
  std::uint64_t tail = 0;
  std::memcpy(&tail, p + i, bytes - i);
  h_ = (h_ ^ mix(tail ^ (std::uint64_t(bytes - i) << 56))) * 0x9fb21c651e98df25ull;
  n_ += bytes;
  return *this;
}

std::uint64_t Hash64::value() const { return mix(h_ ^ n_); }

std::string hex64(std::uint64_t v) {
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(v));
  return buf;
}

std::string Hash64::hex() const { return hex64(value()); }

std::uint64_t hash_file(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw IoError(path + ": cannot read for hashing");
  Hash64 h;
  std::vector<char> buf(kFileChunk);
  while (f) {
    f.read(buf.data(), std::streamsize(buf.size()));
    h.update(buf.data(), std::size_t(f.gcount()));
  }
  return h.value();
}

std::uint64_t hash_file_bytes(const std::string& bytes) {
  Hash64 h;
  std::size_t at = 0;
  for (; at + kFileChunk <= bytes.size(); at += kFileChunk) h.update(bytes.data() + at, kFileChunk);
  h.update(bytes.data() + at, bytes.size() - at);
  return h.value();
}

}  // namespace bsdfmix
