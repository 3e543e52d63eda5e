// Batches over devices of different speeds: measured rates, and runs repeated elsewhere.
#include "device/batch_pool.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <limits>
#include <memory>
#include <thread>

#include "core/error.hpp"

namespace bsdfmix {

namespace {

using Clock = std::chrono::steady_clock;

double seconds(Clock::time_point a, Clock::time_point b) { return std::chrono::duration<double>(b - a).count(); }

}  // namespace

BatchPool::BatchPool(std::vector<Device> devices, int queues_per_device, bool log)
    : devices_(std::move(devices)), log_(log) {
  if (devices_.empty()) throw DeviceError("batch pool: no device given");
  if (queues_per_device < 1)
    throw ConfigError("queues per device must be at least 1, not " + std::to_string(queues_per_device));
  for (std::size_t d = 0; d < devices_.size(); ++d)
    for (int q = 0; q < queues_per_device; ++q) {
      queues_.push_back(devices_[d].make_queue());
      queue_device_.push_back(d);
    }
}

double BatchPool::rate(const std::string& routine, std::size_t d) const {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto it = rates_.find({routine, d});
  return it == rates_.end() ? 0.0 : it->second;
}

void BatchPool::seed_rate(const std::string& routine, std::size_t d, double seconds_per_unit) {
  std::lock_guard<std::mutex> lock(mutex_);
  rates_.emplace(std::make_pair(routine, d), seconds_per_unit);
}

// The hand-out of one BatchPool::run call: which queue starts which batch, the measured
// rates, and the first exception. Its state is under the pool's mutex_.
class BatchPool::Call {
 public:
  Call(BatchPool& pool, const std::string& routine, const std::vector<double>& cost,
       const std::function<void(const BatchRun&)>& fn, bool log)
      : pool_(pool), routine_(routine), cost_(cost), fn_(fn), n_(cost.size()), done_(new std::atomic<bool>[n_]),
        several_(pool.devices_.size() > 1), log_(log), started_(n_, 0), runs_(n_, 0), first_device_(n_, 0),
        first_start_(n_), alive_(pool.queues_.size(), 1) {
    for (std::size_t b = 0; b < n_; ++b) done_[b] = false;
    for (double c : cost) pending_cost_ += c;
  }

  // Queue q takes batches until none is worth its time, or an exception stops the hand-out.
  void worker(std::size_t q) {
    const std::size_t d = pool_.queue_device_[q];
    for (;;) {
      bool repeat = false;
      BatchRun run;
      if (!start(q, d, run, repeat)) return;
      const Clock::time_point t0 = Clock::now();
      try {
        fn_(run);
      } catch (...) {
        std::lock_guard<std::mutex> lock(pool_.mutex_);
        if (!error_) error_ = std::current_exception();
        stop_ = true;
        alive_[q] = 0;
        return;
      }
      finished(run, repeat, seconds(t0, Clock::now()));
    }
  }

  // The first exception of a worker, else a DeviceError for a batch no run finished.
  void finish() const {
    if (error_) std::rethrow_exception(error_);
    for (std::size_t b = 0; b < n_; ++b)
      if (!done_[b]) throw DeviceError(routine_ + ": batch " + std::to_string(b) + " was never finished");
  }

 private:
  // Rate a / rate b on some routine, or 0.
  double ratio(std::size_t a, std::size_t b) const {
    double r = 0;
    for (const auto& [key, value] : pool_.rates_) {
      if (key.second != a) continue;
      const auto other = pool_.rates_.find({key.first, b});
      if (other != pool_.rates_.end() && other->second > 0) r = std::max(r, value / other->second);
    }
    return r;
  }

  // Seconds per unit of this routine on device d: measured, else carried from another
  // routine by the two devices' speed ratio there (a device 1000x slower at EM is taken as
  // 1000x slower at the L1 sums, so that it is not measured again at that cost); where no
  // device is measured on this routine yet, in units of a reference device's time. 0:
  // nothing known.
  double rate_of(std::size_t d) const {
    const auto& rates = pool_.rates_;
    const auto it = rates.find({routine_, d});
    if (it != rates.end()) return it->second;
    bool any_measured = false;
    for (std::size_t e = 0; e < pool_.devices_.size(); ++e) {
      const auto known = rates.find({routine_, e});
      if (known == rates.end()) continue;
      any_measured = true;
      if (const double r = ratio(d, e); r > 0) return known->second * r;
    }
    if (any_measured) return 0.0;
    // No device measured on this routine: the first device measured on any routine is the unit.
    for (std::size_t ref = 0; ref < pool_.devices_.size(); ++ref) {
      const bool measured = std::any_of(rates.begin(), rates.end(), [&](const auto& kv) { return kv.first.second == ref; });
      if (!measured) continue;
      return ref == d ? 1.0 : ratio(d, ref);
    }
    return 0.0;
  }

  // Whether device d should start pending work of cost c now: it has no measured rate yet,
  // it is within 1.5x of the fastest measured device that still takes work (so the fastest
  // never declines, and devices of about one speed share everything), or it would finish c
  // before the faster devices' queues finish all that is pending.
  bool worth(std::size_t d, double c) const {
    const double mine = rate_of(d);
    if (mine <= 0) return true;
    double best = mine, others = 0;  // others: units per second of the other devices' live queues
    for (std::size_t q = 0; q < pool_.queues_.size(); ++q)
      if (alive_[q] && pool_.queue_device_[q] != d)
        if (const double r = rate_of(pool_.queue_device_[q]); r > 0) {
          best = std::min(best, r);
          others += 1.0 / r;
        }
    if (mine <= 1.5 * best) return true;
    return c * mine <= pending_cost_ / others;
  }

  // The next batch device d starts: pending work worth its time (the cheapest one while its
  // rate is unmeasured, to measure it at the least cost), else a batch running only on a
  // slower device that d would finish first. n_ when there is none.
  std::size_t pick(std::size_t d, bool& repeat) {
    repeat = false;
    while (next_ < n_ && started_[next_]) ++next_;
    if (next_ < n_) {
      std::size_t b = next_;
      if (several_ && rate_of(d) <= 0) {
        for (std::size_t i = next_; i < n_; ++i)
          if (!started_[i] && cost_[i] < cost_[b]) b = i;
      }
      if (!several_ || worth(d, cost_[b])) return b;
      return n_;
    }
    if (!several_) return n_;
    const double mine = rate_of(d);
    const Clock::time_point now = Clock::now();
    for (std::size_t b = 0; b < n_; ++b) {
      if (runs_[b] != 1 || done_[b] || first_device_[b] == d) continue;
      const double theirs = rate_of(first_device_[b]);
      // Either rate unknown: race the run (the loser measures itself as at least that slow).
      // Both known: only when d would finish before the first run's expected end.
      if (mine <= 0 || theirs <= 0 || cost_[b] * mine < cost_[b] * theirs - seconds(first_start_[b], now)) {
        repeat = true;
        return b;
      }
    }
    return n_;
  }

  // Picks the next run of queue q (on device d) into `run`; false when the queue stops.
  bool start(std::size_t q, std::size_t d, BatchRun& run, bool& repeat) {
    std::size_t b;
    {
      std::lock_guard<std::mutex> lock(pool_.mutex_);
      if (stop_) return false;
      b = pick(d, repeat);
      if (b == n_) {
        alive_[q] = 0;
        return false;
      }
      if (!started_[b]) {
        started_[b] = 1;
        pending_cost_ -= cost_[b];
        first_device_[b] = d;
        first_start_[b] = Clock::now();
      }
      ++runs_[b];
      if (repeat) ++pool_.repeated_;
      if (several_) {
        double best = 0;
        for (std::size_t e = 0; e < pool_.devices_.size(); ++e)
          if (const double r = rate_of(e); r > 0) best = best > 0 ? std::min(best, r) : r;
        const double mine = rate_of(d);
        run.watched_ = mine <= 0 || mine > 1.5 * best;
      }
    }
    run.batch = b;
    run.device = d;
    run.queue = &pool_.queues_[q];
    run.done_ = &done_[b];
    return true;
  }

  // Logs a finished run and measures the device's rate by it.
  void finished(const BatchRun& run, bool repeat, double took) {
    const std::size_t b = run.batch, d = run.device;
    if (log_)
      std::fprintf(stderr, "pool %s batch %zu/%zu dev %zu [%s] cost %.3g took %.4f s%s%s\n", routine_.c_str(), b, n_, d,
                   pool_.devices_[d].info().name.c_str(), cost_[b], took, repeat ? " (repeat)" : "",
                   run.won_ ? "" : " (lost)");
    if (several_ && cost_[b] > 0) {
      std::lock_guard<std::mutex> lock(pool_.mutex_);
      double& r = pool_.rates_[{routine_, d}];
      const double measured = took / cost_[b];
      // Per queue, as measured with the device's other queues busy. A run that lost the
      // race and stopped early still tells that the device is at least this slow.
      if (r <= 0) r = measured;
      else r = run.won_ ? 0.5 * (r + measured) : std::max(r, measured);
    }
  }

  BatchPool& pool_;
  const std::string& routine_;
  const std::vector<double>& cost_;
  const std::function<void(const BatchRun&)>& fn_;
  const std::size_t n_;
  const std::unique_ptr<std::atomic<bool>[]> done_;
  const bool several_, log_;
  std::vector<char> started_;
  std::vector<int> runs_;
  std::vector<std::size_t> first_device_;
  std::vector<Clock::time_point> first_start_;
  std::size_t next_ = 0;  // batches before it have started
  double pending_cost_ = 0;
  bool stop_ = false;
  std::exception_ptr error_;
  std::vector<char> alive_;
};

void BatchPool::run(const std::string& routine, const std::vector<double>& cost,
                    const std::function<void(const BatchRun&)>& fn) {
  repeated_ = 0;
  if (cost.empty()) return;
  Call call(*this, routine, cost, fn, log_);
  if (queues_.size() == 1) {
    call.worker(0);
  } else {
    std::vector<std::thread> threads;
    for (std::size_t q = 0; q < queues_.size(); ++q) threads.emplace_back([&call, q] { call.worker(q); });
    for (auto& t : threads) t.join();
  }
  call.finish();
}

}  // namespace bsdfmix
