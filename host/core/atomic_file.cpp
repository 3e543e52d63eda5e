// Output files that appear whole or not at all.
#include "core/atomic_file.hpp"

#include <fcntl.h>
#include <sys/statvfs.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "core/error.hpp"

namespace bsdfmix {

namespace fs = std::filesystem;

void prepare_output(const std::string& path, std::uint64_t bytes_needed) {
  fs::path dir = fs::path(path).parent_path();
  if (dir.empty()) dir = ".";
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw IoError(path + ": cannot create directory " + dir.string() + ": " + ec.message());
  if (::access(dir.c_str(), W_OK) != 0)
    throw IoError(path + ": directory " + dir.string() + " is not writable: " + std::strerror(errno));
  struct statvfs st {};
  if (bytes_needed > 0 && ::statvfs(dir.c_str(), &st) == 0) {
    const std::uint64_t free_bytes = static_cast<std::uint64_t>(st.f_bavail) * st.f_frsize;
    if (free_bytes < bytes_needed)
      throw IoError(path + ": not enough free space in " + dir.string() + " (" +
                    std::to_string(bytes_needed >> 20) + " MiB needed, " +
                    std::to_string(free_bytes >> 20) + " MiB free)");
  }
}

AtomicOutput::AtomicOutput(std::string path) : path_(std::move(path)) {
  prepare_output(path_);
  temp_ = path_ + ".partial-" + std::to_string(::getpid());
  std::remove(temp_.c_str());
}

AtomicOutput::~AtomicOutput() {
  if (!committed_) std::remove(temp_.c_str());
}

void AtomicOutput::commit() {
  const int fd = ::open(temp_.c_str(), O_RDONLY);
  if (fd < 0) throw IoError(path_ + ": temporary file vanished before commit: " + std::strerror(errno));
  const int sync_rc = ::fsync(fd);
  ::close(fd);
  if (sync_rc != 0) throw IoError(path_ + ": fsync failed: " + std::strerror(errno));
  if (std::rename(temp_.c_str(), path_.c_str()) != 0)
    throw IoError(path_ + ": cannot rename temporary file into place: " + std::strerror(errno));
  committed_ = true;
  fsync_directory(path_);
}

void fsync_directory(const std::string& path) {
  fs::path dir = fs::path(path).parent_path();
  if (dir.empty()) dir = ".";
  const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) throw IoError(path + ": cannot open directory " + dir.string() + " to sync it: " + std::strerror(errno));
  const int rc = ::fsync(fd);
  const int err = errno;
  ::close(fd);
  if (rc != 0 && err != EINVAL)  // EINVAL: a file system that cannot sync directories
    throw IoError(path + ": fsync of directory " + dir.string() + " failed: " + std::strerror(err));
}

void write_text_atomic(const std::string& path, const std::string& text) {
  AtomicOutput out(path);
  {
    std::ofstream f(out.temp_path(), std::ios::binary);
    f << text;
    f.flush();
    if (!f) throw IoError(path + ": write failed");
  }
  out.commit();
}

std::optional<std::string> read_text(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) return std::nullopt;
  std::ostringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

}  // namespace bsdfmix
