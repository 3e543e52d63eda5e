// Work queues pulling jobs from one shared list: one host thread per queue.
#pragma once

#include <cstddef>
#include <functional>

namespace bsdfmix {

// Runs fn(worker, job) for every job in [0, n_jobs) on n_workers threads; each
// thread takes the next job as soon as it finishes one, so every worker stays busy
// while jobs remain. The first exception stops the hand-out of new jobs and is
// rethrown once all threads have stopped. n_workers == 1 runs on the calling thread.
void run_on_workers(std::size_t n_jobs, std::size_t n_workers,
                    const std::function<void(std::size_t worker, std::size_t job)>& fn);

}  // namespace bsdfmix
