// The one wording of an unreadable input file and of an RGL file where HDF5 belongs.
#include "core/file_errors.hpp"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>

#include "core/error.hpp"

namespace bsdfmix {

namespace {
constexpr char kRglMagic[] = "tensor_file";  // with its terminating zero: the 12 bytes an RGL file starts with
}  // namespace

std::string unreadable_file(const std::string& path) {
  std::error_code ec;
  const auto status = std::filesystem::status(path, ec);
  if (!std::filesystem::exists(status)) return path + ": no such file";
  if (std::filesystem::is_directory(status)) return path + ": is a directory, not a file";
  FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) return path + ": cannot read it (" + std::strerror(errno) + ")";
  std::fclose(f);
  return "";
}

void require_readable(const std::string& path) {
  if (const std::string why = unreadable_file(path); !why.empty()) throw InputError(why);
}

std::string rgl_file_hint(const std::string& path, const std::string& head) {
  if (head.size() < sizeof kRglMagic || std::memcmp(head.data(), kRglMagic, sizeof kRglMagic) != 0) return "";
  return path + ": this is an RGL file: import it with `bsdfmix import rgl " + path + " -o TABLE.h5`";
}

std::string file_head(const std::string& path, std::size_t n) {
  std::string out(n, '\0');
  FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) return "";
  out.resize(std::fread(&out[0], 1, n, f));
  std::fclose(f);
  return out;
}

}  // namespace bsdfmix
