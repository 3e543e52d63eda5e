// Batches of device work over the queues of devices that may differ in speed by orders of
// magnitude (a GPU beside a CPU, PoCL beside oclgrind): each device takes work only while
// it would finish it before the others finish everything left, by its measured seconds per
// unit of work, and a batch still running on a slower device when nothing else is left is
// run again on a faster one; the first run to finish is the one kept, the other stops at
// its next launch.
#pragma once

#include <atomic>
#include <cstddef>
#include <functional>
#include <map>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include "device/device.hpp"

namespace bsdfmix {

// One run of one batch on one queue, as BatchPool::run hands it to the routine.
class BatchRun {
 public:
  std::size_t batch = 0;   // the batch's index in the call
  std::size_t device = 0;  // the device's index in the pool
  const cl::CommandQueue* queue = nullptr;
  // Another run of this batch has finished: stop before the next launch (results unused).
  bool cancelled() const { return done_->load(std::memory_order_acquire); }
  // Whether this run may well lose to another device (several devices, and this one
  // unmeasured or slower than the fastest): a routine then checks cancelled() after every
  // launch rather than every few, at the price of a wait per launch.
  bool watched() const { return watched_; }
  // True for the first run of the batch that finishes, exactly once: only that run writes
  // the batch's results.
  bool claim() const {
    bool expected = false;
    won_ = done_->compare_exchange_strong(expected, true, std::memory_order_acq_rel);
    return won_;
  }

 private:
  friend class BatchPool;
  std::atomic<bool>* done_ = nullptr;
  mutable bool won_ = false;
  bool watched_ = false;
};

// Seconds per unit of work kept per (routine, device) over the pool's life.
class BatchPool {
 public:
  // log: print every run (routine, batch, device, cost, seconds, kept or repeated).
  BatchPool(std::vector<Device> devices, int queues_per_device, bool log = false);

  const std::vector<Device>& devices() const { return devices_; }
  std::size_t queue_count() const { return queues_.size(); }

  // Runs fn once for every batch (cost[b]: its work, in a unit common to the routine; the
  // unit only has to be proportional to the time). `routine` names what runs, for the
  // measured rates. With one device every queue takes the next batch as soon as it is
  // free. The first exception stops the hand-out and is rethrown once every queue is idle.
  void run(const std::string& routine, const std::vector<double>& cost,
           const std::function<void(const BatchRun&)>& fn);

  // Runs of the last call that were started again on another device (for the log).
  std::size_t repeated() const { return repeated_; }
  // The measured seconds per unit of `routine` on device d (0 while unmeasured).
  double rate(const std::string& routine, std::size_t d) const;
  // Sets it, as measured elsewhere (a calibration run), for a device not yet measured.
  void seed_rate(const std::string& routine, std::size_t d, double seconds_per_unit);

 private:
  class Call;  // the hand-out of one run() call (batch_pool.cpp)
  std::vector<Device> devices_;
  bool log_ = false;
  std::vector<cl::CommandQueue> queues_;
  std::vector<std::size_t> queue_device_;
  mutable std::mutex mutex_;
  std::map<std::pair<std::string, std::size_t>, double> rates_;
  std::size_t repeated_ = 0;
};

}  // namespace bsdfmix
