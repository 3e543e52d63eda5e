// Progress of long work on stderr.
#include "core/progress.hpp"

#include <unistd.h>

#include <atomic>
#include <cstdio>

namespace bsdfmix {

namespace {
std::atomic<bool> g_enabled{true};

std::string format_seconds(double s) {
  char buf[32];
  if (s < 60) std::snprintf(buf, sizeof buf, "%.0fs", s);
  else if (s < 3600) std::snprintf(buf, sizeof buf, "%dm%02ds", int(s) / 60, int(s) % 60);
  else std::snprintf(buf, sizeof buf, "%dh%02dm", int(s) / 3600, (int(s) % 3600) / 60);
  return buf;
}
}  // namespace

void Progress::set_enabled(bool on) { g_enabled = on; }
bool Progress::enabled() { return g_enabled; }

void log_line(const std::string& text) {
  if (g_enabled) std::fprintf(stderr, "bsdfmix: %s\n", text.c_str());
}

void warn_line(const std::string& text) { std::fprintf(stderr, "warning: %s\n", text.c_str()); }

Progress::Progress(std::string what, std::uint64_t total, std::string unit)
    : what_(std::move(what)), unit_(std::move(unit)), total_(total),
      start_(std::chrono::steady_clock::now()), last_print_(start_),
      tty_(::isatty(STDERR_FILENO) != 0) {}

Progress::~Progress() = default;  // silent: an unfinished task (an error) prints no summary

void Progress::advance(std::uint64_t n) {
  std::lock_guard<std::mutex> lock(mutex_);
  done_ += n;
  const auto now = std::chrono::steady_clock::now();
  const double since = std::chrono::duration<double>(now - last_print_).count();
  if (since >= (tty_ ? 0.2 : 10.0)) {
    last_print_ = now;
    print(false);
  }
}

void Progress::finish() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (finished_) return;
  finished_ = true;
  print(true);
}

void Progress::print(bool final_line) {
  if (!g_enabled) return;
  const double elapsed =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  const double rate = elapsed > 0 ? double(done_) / elapsed : 0.0;
  char line[256];
  if (final_line) {
    std::snprintf(line, sizeof line, "%s: %llu/%llu %s in %s (%.1f %s/s)", what_.c_str(),
                  (unsigned long long)done_, (unsigned long long)total_, unit_.c_str(),
                  format_seconds(elapsed).c_str(), rate, unit_.c_str());
  } else {
    // a total that is an estimate (a render's passes in a time budget) may be passed
    const double eta = rate > 0 && done_ < total_ ? double(total_ - done_) / rate : 0.0;
    std::snprintf(line, sizeof line, "%s: %llu/%llu %s (%.0f%%), %.1f %s/s, ETA %s", what_.c_str(),
                  (unsigned long long)done_, (unsigned long long)total_, unit_.c_str(),
                  total_ ? 100.0 * double(done_) / double(total_) : 100.0, rate, unit_.c_str(),
                  format_seconds(eta).c_str());
  }
  if (tty_) std::fprintf(stderr, "\r\033[Kbsdfmix: %s%s", line, final_line ? "\n" : "");
  else std::fprintf(stderr, "bsdfmix: %s\n", line);
  std::fflush(stderr);
}

}  // namespace bsdfmix
