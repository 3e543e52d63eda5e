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

void BatchPool::run(const std::string& routine, const std::vector<double>& cost,
                    const std::function<void(const BatchRun&)>& fn) {
  const std::size_t n = cost.size();
  repeated_ = 0;
  if (n == 0) return;
  const std::unique_ptr<std::atomic<bool>[]> done(new std::atomic<bool>[n]);
  for (std::size_t b = 0; b < n; ++b) done[b] = false;
  const bool several = devices_.size() > 1;

  // Hand-out state, under mutex_.
  std::vector<char> started(n, 0);
  std::vector<int> runs(n, 0);
  std::vector<std::size_t> first_device(n, 0);
  std::vector<Clock::time_point> first_start(n);
  std::size_t next = 0;  // batches before it have started
  double pending_cost = 0;
  for (double c : cost) pending_cost += c;
  bool stop = false;
  std::exception_ptr error;

  // Seconds per unit of this routine on device d, under mutex_: measured, else carried from
  // another routine by the two devices' speed ratio there (a device 1000x slower at EM is
  // taken as 1000x slower at the L1 sums, so that it is not measured again at that cost);
  // where no device is measured on this routine yet, in units of a reference device's time.
  // 0: nothing known.
  auto rate_of = [&](std::size_t d) {
    const auto it = rates_.find({routine, d});
    if (it != rates_.end()) return it->second;
    auto ratio = [&](std::size_t a, std::size_t b) {  // rate a / rate b on some routine, or 0
      double r = 0;
      for (const auto& [key, value] : rates_) {
        if (key.second != a) continue;
        const auto other = rates_.find({key.first, b});
        if (other != rates_.end() && other->second > 0) r = std::max(r, value / other->second);
      }
      return r;
    };
    bool any_measured = false;
    for (std::size_t e = 0; e < devices_.size(); ++e) {
      const auto known = rates_.find({routine, e});
      if (known == rates_.end()) continue;
      any_measured = true;
      if (const double r = ratio(d, e); r > 0) return known->second * r;
    }
    if (any_measured) return 0.0;
    // No device measured on this routine: the first device measured on any routine is the unit.
    for (std::size_t ref = 0; ref < devices_.size(); ++ref) {
      const bool measured = std::any_of(rates_.begin(), rates_.end(), [&](const auto& kv) { return kv.first.second == ref; });
      if (!measured) continue;
      return ref == d ? 1.0 : ratio(d, ref);
    }
    return 0.0;
  };
  // Whether device d should start pending work of cost c now: it has no measured rate yet,
  // it is within 1.5x of the fastest measured device that still takes work (so the fastest
  // never declines, and devices of about one speed share everything), or it would finish c
  // before the faster devices' queues finish all that is pending.
  std::vector<char> alive(queues_.size(), 1);
  auto worth = [&](std::size_t d, double c) {
    const double mine = rate_of(d);
    if (mine <= 0) return true;
    double best = mine, others = 0;  // others: units per second of the other devices' live queues
    for (std::size_t q = 0; q < queues_.size(); ++q)
      if (alive[q] && queue_device_[q] != d)
        if (const double r = rate_of(queue_device_[q]); r > 0) {
          best = std::min(best, r);
          others += 1.0 / r;
        }
    if (mine <= 1.5 * best) return true;
    return c * mine <= pending_cost / others;
  };
  // The next batch device d starts: pending work worth its time (the cheapest one while its
  // rate is unmeasured, to measure it at the least cost), else a batch running only on a
  // slower device that d would finish first. n when there is none.
  auto pick = [&](std::size_t d, bool& repeat) -> std::size_t {
    repeat = false;
    while (next < n && started[next]) ++next;
    if (next < n) {
      std::size_t b = next;
      if (several && rate_of(d) <= 0) {
        for (std::size_t i = next; i < n; ++i)
          if (!started[i] && cost[i] < cost[b]) b = i;
      }
      if (!several || worth(d, cost[b])) return b;
      return n;
    }
    if (!several) return n;
    const double mine = rate_of(d);
    const Clock::time_point now = Clock::now();
    for (std::size_t b = 0; b < n; ++b) {
      if (runs[b] != 1 || done[b] || first_device[b] == d) continue;
      const double theirs = rate_of(first_device[b]);
      // Either rate unknown: race the run (the loser measures itself as at least that slow).
      // Both known: only when d would finish before the first run's expected end.
      if (mine <= 0 || theirs <= 0 || cost[b] * mine < cost[b] * theirs - seconds(first_start[b], now)) {
        repeat = true;
        return b;
      }
    }
    return n;
  };

  auto worker = [&](std::size_t q) {
    const std::size_t d = queue_device_[q];
    for (;;) {
      std::size_t b;
      bool repeat = false;
      BatchRun run;
      {
        std::lock_guard<std::mutex> lock(mutex_);
        if (stop) return;
        b = pick(d, repeat);
        if (b == n) {
          alive[q] = 0;
          return;
        }
        if (!started[b]) {
          started[b] = 1;
          pending_cost -= cost[b];
          first_device[b] = d;
          first_start[b] = Clock::now();
        }
        ++runs[b];
        if (repeat) ++repeated_;
        if (several) {
          double best = 0;
          for (std::size_t e = 0; e < devices_.size(); ++e)
            if (const double r = rate_of(e); r > 0) best = best > 0 ? std::min(best, r) : r;
          const double mine = rate_of(d);
          run.watched_ = mine <= 0 || mine > 1.5 * best;
        }
      }
      run.batch = b;
      run.device = d;
      run.queue = &queues_[q];
      run.done_ = &done[b];
      const Clock::time_point t0 = Clock::now();
      try {
        fn(run);
      } catch (...) {
        std::lock_guard<std::mutex> lock(mutex_);
        if (!error) error = std::current_exception();
        stop = true;
        alive[q] = 0;
        return;
      }
      const double took = seconds(t0, Clock::now());
      if (log_)
        std::fprintf(stderr, "pool %s batch %zu/%zu dev %zu [%s] cost %.3g took %.4f s%s%s\n", routine.c_str(), b, n, d,
                     devices_[d].info().name.c_str(), cost[b], took, repeat ? " (repeat)" : "", run.won_ ? "" : " (lost)");
      if (several && cost[b] > 0) {
        std::lock_guard<std::mutex> lock(mutex_);
        double& r = rates_[{routine, d}];
        const double measured = took / cost[b];
        // Per queue, as measured with the device's other queues busy. A run that lost the
        // race and stopped early still tells that the device is at least this slow.
        if (r <= 0) r = measured;
        else r = run.won_ ? 0.5 * (r + measured) : std::max(r, measured);
      }
    }
  };

  if (queues_.size() == 1) {
    worker(0);
  } else {
    std::vector<std::thread> threads;
    for (std::size_t q = 0; q < queues_.size(); ++q) threads.emplace_back(worker, q);
    for (auto& t : threads) t.join();
  }
  if (error) std::rethrow_exception(error);
  for (std::size_t b = 0; b < n; ++b)
    if (!done[b]) throw DeviceError(routine + ": batch " + std::to_string(b) + " was never finished");
}

}  // namespace bsdfmix
