// Exclusive output locks with flock(2): a killed holder releases its lock with its
// file descriptors, so a lock file left on disk never blocks the next run.
#include "core/output_lock.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <ctime>
#include <string>

#include "core/atomic_file.hpp"
#include "core/error.hpp"

namespace bsdfmix {

namespace {

std::string holder_text(int fd) {
  char buf[256] = {};
  const ssize_t n = ::pread(fd, buf, sizeof buf - 1, 0);
  std::string s = n > 0 ? std::string(buf, std::size_t(n)) : std::string("an unknown process");
  while (!s.empty() && (s.back() == '\n' || s.back() == ' ')) s.pop_back();
  return s;
}

std::string own_text() {
  char host[128] = "?";
  ::gethostname(host, sizeof host - 1);
  char when[32] = "?";
  const std::time_t now = std::time(nullptr);
  std::tm tm{};
  if (::gmtime_r(&now, &tm)) std::strftime(when, sizeof when, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return "pid " + std::to_string(::getpid()) + " on " + host + " since " + when + "\n";
}

}  // namespace

OutputLock::OutputLock(const std::string& output) : path_(output + ".lock") {
  prepare_output(path_);
  // The holder may unlink the file as it ends; lock again until the locked file is
  // the one the path names.
  for (int attempt = 0; attempt < 100; ++attempt) {
    const int fd = ::open(path_.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd < 0) throw IoError(path_ + ": cannot open lock file: " + std::strerror(errno));
    if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
      const int err = errno;
      const std::string holder = holder_text(fd);
      ::close(fd);
      if (err == EWOULDBLOCK)
        throw IoError(output + ": in use by another bsdfmix run (" + holder + ", lock " + path_ + ")");
      throw IoError(path_ + ": cannot lock: " + std::strerror(err));
    }
    struct stat held {}, named {};
    if (::fstat(fd, &held) == 0 && ::stat(path_.c_str(), &named) == 0 && held.st_ino == named.st_ino &&
        held.st_dev == named.st_dev) {
      const std::string me = own_text();
      if (::ftruncate(fd, 0) != 0 || ::pwrite(fd, me.data(), me.size(), 0) != ssize_t(me.size())) {
        ::close(fd);
        throw IoError(path_ + ": cannot write lock file: " + std::strerror(errno));
      }
      fd_ = fd;
      return;
    }
    ::close(fd);  // locked a file its holder had just removed
  }
  throw IoError(path_ + ": cannot take the lock (the lock file keeps being replaced)");
}

OutputLock::~OutputLock() {
  if (fd_ < 0) return;
  ::unlink(path_.c_str());  // while still held: a waiting opener sees another inode and retries
  ::close(fd_);
}

}  // namespace bsdfmix
