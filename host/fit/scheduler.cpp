// Work queues pulling jobs from one shared list.
#include "fit/scheduler.hpp"

#include <atomic>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

namespace bsdfmix {

void run_on_workers(std::size_t n_jobs, std::size_t n_workers,
                    const std::function<void(std::size_t, std::size_t)>& fn) {
  if (n_jobs == 0) return;
  if (n_workers <= 1) {
    for (std::size_t j = 0; j < n_jobs; ++j) fn(0, j);
    return;
  }
  std::atomic<std::size_t> next{0};
  std::atomic<bool> stop{false};
  std::exception_ptr error;
  std::mutex error_mutex;
  auto body = [&](std::size_t worker) {
    while (!stop) {
      const std::size_t job = next.fetch_add(1);
      if (job >= n_jobs) break;
      try {
        fn(worker, job);
      } catch (...) {
        std::lock_guard<std::mutex> lock(error_mutex);
        if (!error) error = std::current_exception();
        stop = true;
      }
    }
  };
  std::vector<std::thread> threads;
  for (std::size_t w = 0; w < n_workers; ++w) threads.emplace_back(body, w);
  for (auto& t : threads) t.join();
  if (error) std::rethrow_exception(error);
}

}  // namespace bsdfmix
