// A 64-bit content hash for fingerprints (not cryptographic): the same bytes give the
// same value on every machine; any changed byte changes it with overwhelming odds.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

namespace bsdfmix {

class Hash64 {
 public:
  Hash64& update(const void* data, std::size_t bytes);
  Hash64& update(std::uint64_t v) { return update(&v, sizeof v); }
  std::uint64_t value() const;
  std::string hex() const;  // 16 hex digits

 private:
  std::uint64_t h_ = 0x6a09e667f3bcc908ull, n_ = 0;
};

// SplitMix64 (Steele et al. 2014): x advanced by the golden-ratio increment, then mixed.
// The fits derive their seeds from (seed, slice, K, restart) with it and step the
// initialization's random stream by it (host/fit/em_common.cpp, host/sweep/sweep.cpp).
inline std::uint64_t splitmix64(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

// The hash of a whole file's bytes; IoError when it cannot be read.
std::uint64_t hash_file(const std::string& path);

// hash_file's value for a file whose bytes, already in memory, are `bytes`.
std::uint64_t hash_file_bytes(const std::string& bytes);

std::string hex64(std::uint64_t v);

}  // namespace bsdfmix
