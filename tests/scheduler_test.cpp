// The work-queue scheduler, and EM results independent of how many devices and
// queues ran them: PoCL presents two CPU devices with POCL_DEVICES="pthread pthread".
// labels: em
#include <catch2/catch.hpp>

#include <atomic>
#include <condition_variable>
#include <chrono>
#include <cstdlib>
#include <mutex>
#include <set>
#include <stdexcept>
#include <thread>

#include "core/error.hpp"
#include "core/progress.hpp"
#include "fit/em.hpp"
#include "device/batch_pool.hpp"
#include "fit/scheduler.hpp"
#include "fit/synthetic.hpp"

using namespace bsdfmix;

namespace {
// Before the first OpenCL call of this process.
const int kPoclDevices = [] {
  setenv("POCL_DEVICES", "pthread pthread", 1);
  unsetenv("BSDFMIX_DEVICE");
  Progress::set_enabled(false);
  return 0;
}();
}  // namespace

TEST_CASE("run_on_workers runs every job once and keeps every worker busy", "[scheduler]") {
  std::vector<std::atomic<int>> runs(40);
  std::mutex m;
  std::set<std::size_t> workers;
  std::condition_variable all_in;
  // Each job waits until three distinct workers hold a job: the run completes only if
  // every worker takes part, on any machine and under any load (no clock involved).
  run_on_workers(runs.size(), 3, [&](std::size_t w, std::size_t j) {
    ++runs[j];
    std::unique_lock<std::mutex> lock(m);
    workers.insert(w);
    all_in.notify_all();
    all_in.wait(lock, [&] { return workers.size() == 3; });
  });
  for (auto& r : runs) CHECK(r == 1);
  CHECK(workers.size() == 3);
}

TEST_CASE("run_on_workers rethrows the first error and stops handing out jobs", "[scheduler]") {
  std::atomic<int> started{0};
  CHECK_THROWS_WITH(run_on_workers(1000, 2,
                                   [&](std::size_t, std::size_t j) {
                                     ++started;
                                     if (j == 3) throw std::runtime_error("job 3 failed");
                                     std::this_thread::sleep_for(std::chrono::microseconds(200));
                                   }),
                    "job 3 failed");
  CHECK(started < 1000);
}

TEST_CASE("1, 2 and 3 devices or queues give identical mixtures", "[scheduler]") {
  const auto both = select_devices("0,1");
  REQUIRE(both.size() == 2);
  SliceSet set;
  set.grid = make_slice_grid(Domain::Fiber, 30, 60);
  for (int s = 0; s < 6; ++s) set.weights.push_back(mixture_weights(set.grid, synthetic_lobes(Domain::Fiber, 4, s + 11)));
  EmSettings st;
  st.iterations = 40;
  st.restarts = 2;
  std::vector<EmTask> tasks;
  for (std::size_t s = 0; s < set.weights.size(); ++s)
    for (int k : {1, 3, 5, 9}) tasks.push_back({s, k, st});

  struct Setup {
    const char* name;
    std::vector<Device> devices;
    int queues;
  };
  const std::vector<Setup> setups = {{"1 device, 1 queue", {both[0]}, 1},
                                     {"2 devices, 1 queue each", both, 1},
                                     {"1 device, 3 queues", {both[1]}, 3},
                                     {"2 devices, 3 queues each", both, 3}};
  std::vector<std::vector<EmResult>> results;
  for (const auto& s : setups) {
    EmEngine engine(s.devices, s.queues);
    engine.set_batch_budget(1 << 15);  // many small batches
    Progress progress("fit", tasks.size(), "tasks");
    results.push_back(engine.fit(set, tasks, &progress));
    CHECK(engine.last_timing().batches > engine.queue_count());
  }
  for (std::size_t c = 1; c < setups.size(); ++c) {
    INFO(setups[c].name << " vs " << setups[0].name);
    for (std::size_t i = 0; i < tasks.size(); ++i) {
      const EmResult& a = results[0][i];
      const EmResult& b = results[c][i];
      REQUIRE(a.ok);
      REQUIRE(b.ok);
      CHECK(a.loglik == b.loglik);
      CHECK(a.iterations == b.iterations);
      CHECK(a.gmm.weight == b.gmm.weight);
      CHECK(a.gmm.mean == b.gmm.mean);
      CHECK(a.gmm.cov == b.gmm.cov);
    }
  }
}

TEST_CASE("BatchPool: a batch stuck on one device is run again on the other, and kept once", "[scheduler]") {
  const auto both = select_devices("0,1");
  REQUIRE(both.size() == 2);
  BatchPool pool(both, 1);
  // Device 1 is stuck: in the first call (its rate unmeasured) each of its runs waits until
  // another run of the same batch has claimed it, so the call completes only if device 0
  // takes over what device 1 holds; later, until that or until every other batch is claimed.
  // No clock decides anything. Every batch must be claimed by exactly one run.
  for (int call = 0; call < 3; ++call) {
    const std::size_t n = 12;
    std::vector<std::atomic<int>> claimed(n);
    std::atomic<int> total{0}, stuck{0};
    pool.run("test", std::vector<double>(n, 1.0), [&](const BatchRun& run) {
      if (run.device == 1) {
        ++stuck;
        while (!run.cancelled() && (call == 0 || total < static_cast<int>(n) - 1)) std::this_thread::yield();
      }
      if (run.claim()) {
        ++claimed[run.batch];
        ++total;
      }
    });
    for (std::size_t b = 0; b < n; ++b) CHECK(claimed[b] == 1);
    if (call == 0 && stuck > 0) CHECK(pool.repeated() >= 1);
  }
  CHECK(pool.rate("test", 0) > 0);
}

TEST_CASE("BatchPool: an error stops the hand-out and is rethrown", "[scheduler]") {
  BatchPool pool(select_devices("0"), 2);
  std::atomic<int> started{0};
  CHECK_THROWS_WITH(pool.run("test", std::vector<double>(500, 1.0),
                             [&](const BatchRun& run) {
                               ++started;
                               if (run.batch == 3) throw std::runtime_error("batch 3 failed");
                               run.claim();
                             }),
                    "batch 3 failed");
  CHECK(started < 500);
}

TEST_CASE("a device's largest allocation splits the batches, and only a slice too large for it fails", "[scheduler]") {
  const Device pocl = select_devices("0").front();
  SliceSet set;
  set.grid = make_slice_grid(Domain::Fiber, 30, 60);  // 1800 cells: a stride of 2048
  for (int s = 0; s < 6; ++s) set.weights.push_back(mixture_weights(set.grid, synthetic_lobes(Domain::Fiber, 4, s + 21)));
  EmSettings st;
  st.iterations = 20;
  st.restarts = 1;
  std::vector<EmTask> tasks;
  for (std::size_t s = 0; s < set.weights.size(); ++s) tasks.push_back({s, 4, st});
  EmEngine plain({pocl});
  const auto expected = plain.fit(set, tasks);
  CHECK(plain.last_timing().batches == 1);

  // The same device, reporting 32 KiB in one allocation: a problem (2048 cells x bucket 4,
  // 4 bytes each) fits alone, so the work is cut into one batch per problem.
  DeviceInfo small_info = pocl.info();
  small_info.max_alloc = 32 * 1024;
  EmEngine small({Device(pocl.cl_device(), small_info)});
  const auto got = small.fit(set, tasks);
  CHECK(small.last_timing().batches == tasks.size());
  for (std::size_t i = 0; i < tasks.size(); ++i) {
    REQUIRE(got[i].ok);
    CHECK(got[i].loglik == expected[i].loglik);
    CHECK(got[i].gmm.mean == expected[i].gmm.mean);
  }

  // 16 KiB: a single slice cannot fit, a one-line error naming the bytes and the limit.
  small_info.max_alloc = 16 * 1024;
  EmEngine tiny({Device(pocl.cl_device(), small_info)});
  try {
    tiny.fit(set, tasks);
    FAIL("a slice larger than the device's largest allocation was fitted");
  } catch (const DeviceError& e) {
    const std::string what = e.what();
    CHECK_THAT(what, Catch::Contains("a slice of 2048 padded cells at 4 components needs 32768 bytes"));
    CHECK_THAT(what, Catch::Contains("(16384)"));
    CHECK(what.find('\n') == std::string::npos);
  }
}
