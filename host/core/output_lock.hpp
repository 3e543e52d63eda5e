// One writer per output: an exclusive lock on `<output>.lock`, held for the life of the
// object and released by the kernel when the process ends, however it ends.
#pragma once

#include <string>

namespace bsdfmix {

class OutputLock {
 public:
  // Takes the lock or throws IoError at once, naming the output and the run that
  // holds it (pid, host, start time).
  explicit OutputLock(const std::string& output);
  ~OutputLock();
  OutputLock(const OutputLock&) = delete;
  OutputLock& operator=(const OutputLock&) = delete;

  const std::string& path() const { return path_; }

 private:
  std::string path_;
  int fd_ = -1;
};

}  // namespace bsdfmix
