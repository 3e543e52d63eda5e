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

// The hash of a whole file's bytes; IoError when it cannot be read.
std::uint64_t hash_file(const std::string& path);

std::string hex64(std::uint64_t v);

}  // namespace bsdfmix
