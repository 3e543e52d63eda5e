// Batches fitted side by side: one thread per lane (one lane: the calling thread), each
// with its engine and fitter; the calling thread commits what they finish.
#include "sweep/batch_lanes.hpp"

#include <algorithm>
#include <condition_variable>
#include <deque>
#include <exception>
#include <mutex>
#include <thread>

#include "core/progress.hpp"
#include "sweep/batch_fitter.hpp"

namespace bsdfmix {

namespace {

// A source whose reads take the lanes' file lock.
class LockedSource final : public SliceSource {
 public:
  LockedSource(const SliceSource& source, std::mutex& file) : source_(source), file_(file) {}
  const TableMeta& meta() const override { return source_.meta(); }
  std::vector<double> weights(const SliceRef& ref) const override {
    const std::lock_guard<std::mutex> lock(file_);
    return source_.weights(ref);
  }
  std::vector<double> rgb_weights(const SliceRef& ref) const override {
    const std::lock_guard<std::mutex> lock(file_);
    return source_.rgb_weights(ref);
  }

 private:
  const SliceSource& source_;
  std::mutex& file_;
};

struct Lane {
  Lane(const SliceSource& source, const FitSettings& fit, const std::vector<Device>& devices,
       const EngineOptions& options, const std::string& names)
      : engine(devices, 1, options), fitter(source, fit, engine, names) {}
  EmEngine engine;
  BatchFitter fitter;
};

// The lanes a run can use of the `requested`: 1 where a device takes one host thread at
// a time (said on the log), else `requested`.
unsigned usable_lanes(unsigned requested, const std::vector<Device>& devices) {
  if (requested <= 1) return 1;
  for (const Device& d : devices)
    if (!d.info().concurrent_host_threads()) {
      log_line(d.info().label() + " takes one host thread at a time: fitting one batch at a time");
      return 1;
    }
  return requested;
}

}  // namespace

struct BatchLanes::Impl {
  const FitSettings& fit;
  const std::vector<Device>& devices;
  const EngineOptions options;
  const std::string names;
  const unsigned usable;

  std::mutex file;  // the table's reads and the commits
  LockedSource source;

  std::mutex mutex;  // what follows
  std::condition_variable changed;
  std::size_t next = 0, running = 0;
  std::deque<BatchPart> done;
  std::exception_ptr error;

  Impl(const SliceSource& s, const FitSettings& fit_, const std::vector<Device>& devices_,
       const EngineOptions& options_, const std::string& names_, unsigned requested)
      : fit(fit_), devices(devices_), options(options_), names(names_), usable(usable_lanes(requested, devices_)),
        source(s, file) {}

  std::unique_ptr<Lane> lane() { return std::make_unique<Lane>(source, fit, devices, options, names); }

  void work(Lane& lane, const std::vector<std::vector<SliceRef>>& batches) {
    for (;;) {
      std::size_t i;
      {
        const std::lock_guard<std::mutex> lock(mutex);
        if (error || next == batches.size()) break;
        i = next++;
      }
      try {
        BatchPart part = lane.fitter.fit(batches[i]);
        const std::lock_guard<std::mutex> lock(mutex);
        done.push_back(std::move(part));
      } catch (...) {
        const std::lock_guard<std::mutex> lock(mutex);
        if (!error) error = std::current_exception();
      }
      changed.notify_all();
    }
    const std::lock_guard<std::mutex> lock(mutex);
    --running;
    changed.notify_all();
  }
};

BatchLanes::BatchLanes(const SliceSource& source, const FitSettings& fit, const std::vector<Device>& devices,
                       const EngineOptions& engine, const std::string& device_names, unsigned lanes)
    : impl_(std::make_unique<Impl>(source, fit, devices, engine, device_names, lanes)) {}

BatchLanes::~BatchLanes() = default;

void BatchLanes::run(const std::vector<std::vector<SliceRef>>& batches,
                     const std::function<void(BatchPart&&)>& commit) {
  Impl& m = *impl_;
  const std::size_t n = std::min<std::size_t>(m.usable, batches.size());
  if (n <= 1) {  // one lane: on this thread, in order
    const std::unique_ptr<Lane> lane = m.lane();
    for (const auto& b : batches) commit(lane->fitter.fit(b));
    return;
  }
  std::vector<std::unique_ptr<Lane>> lanes;
  for (std::size_t i = 0; i < n; ++i) lanes.push_back(m.lane());
  m.next = 0;
  m.error = nullptr;
  m.running = n;
  std::vector<std::thread> threads;
  for (auto& lane : lanes) threads.emplace_back([&m, &lane, &batches] { m.work(*lane, batches); });
  std::unique_lock<std::mutex> lock(m.mutex);
  for (;;) {
    m.changed.wait(lock, [&] { return !m.done.empty() || m.running == 0; });
    if (m.done.empty()) break;
    BatchPart part = std::move(m.done.front());
    m.done.pop_front();
    lock.unlock();
    try {
      const std::lock_guard<std::mutex> file(m.file);
      commit(std::move(part));
    } catch (...) {
      lock.lock();
      if (!m.error) m.error = std::current_exception();
      continue;
    }
    lock.lock();
  }
  lock.unlock();
  for (auto& t : threads) t.join();
  if (m.error) std::rethrow_exception(m.error);
}

}  // namespace bsdfmix
