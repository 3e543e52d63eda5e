// Progress of long work on stderr: a live line with rate and ETA on a terminal,
// periodic plain log lines otherwise (so CI logs stay readable).
#pragma once

#include <chrono>
#include <cstdint>
#include <mutex>
#include <string>

namespace bsdfmix {

class Progress {
 public:
  // `what` names the work ("fit silk.h5"), `unit` the items counted ("slices").
  Progress(std::string what, std::uint64_t total, std::string unit);
  ~Progress();
  void advance(std::uint64_t n = 1);  // thread-safe
  void finish();                      // prints the final line once; not called on errors

  // Off: nothing printed (tests, --quiet). Default: on.
  static void set_enabled(bool on);
  static bool enabled();

 private:
  void print(bool final_line);
  std::string what_, unit_;
  std::uint64_t total_, done_ = 0;
  std::chrono::steady_clock::time_point start_, last_print_;
  bool tty_, finished_ = false;
  std::mutex mutex_;
};

// One log line on stderr, prefixed "bsdfmix: ", unless logging is off.
void log_line(const std::string& text);

// One warning on stderr, "warning: " and the text (what is wrong and what to do),
// printed even when logging is off: it may save a wasted fit.
void warn_line(const std::string& text);

}  // namespace bsdfmix
