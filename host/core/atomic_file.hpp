// Output files that appear whole or not at all: written under a temporary name, then renamed.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

namespace bsdfmix {

// Creates the parent directory of `path` if needed and checks that it is writable
// and has at least `bytes_needed` free; throws IoError naming the path otherwise.
// Call before spending work on a result.
void prepare_output(const std::string& path, std::uint64_t bytes_needed = 0);

// A file written under a temporary name beside `path` and renamed over it by
// commit(). Destroyed without commit(), the temporary is removed: a crash or an
// error never leaves a half-written file under the final name.
class AtomicOutput {
 public:
  explicit AtomicOutput(std::string path);
  ~AtomicOutput();
  AtomicOutput(const AtomicOutput&) = delete;
  AtomicOutput& operator=(const AtomicOutput&) = delete;

  const std::string& temp_path() const { return temp_; }
  const std::string& path() const { return path_; }
  void commit();  // fsync, rename, fsync of the directory; throws IoError

 private:
  std::string path_, temp_;
  bool committed_ = false;
};

// Makes the directory entry of `path` durable (after a rename or a create).
void fsync_directory(const std::string& path);

// Writes `text` to `path` atomically.
void write_text_atomic(const std::string& path, const std::string& text);

// The whole of a file as bytes; nullopt when it cannot be opened.
std::optional<std::string> read_text(const std::string& path);

}  // namespace bsdfmix
