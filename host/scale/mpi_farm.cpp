// The MPI task farm: rank 0 hands out batches and commits the parts; workers fit.
//
// Messages (MPI_COMM_WORLD, MPI_BYTE):
//   rank 0 -> worker  kTask  u64 job, u64 map (0 theta_phi, 1 equal_area: fit.map with auto
//                            chosen), u64 n, n x (u64 index, u64 t_o, u64 p_o)
//                     kStop  empty: no more work; answer kBye and end
//   worker -> rank 0  kPart  f64 seconds of fitting, then the part (scale/part_codec.hpp)
//                     kError the error text of a failed fit
//                     kBye   empty: stopped, nothing more will come
// Tasks reach a worker in the order they were sent, and its parts come back in that
// order, so rank 0 knows which batch each part is.
#include "scale/mpi_farm.hpp"

#include <mpi.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <deque>
#include <thread>

#include "core/error.hpp"
#include "core/hash.hpp"
#include "core/progress.hpp"
#include "scale/part_codec.hpp"
#include "sweep/sweep.hpp"

namespace bsdfmix::scale {

namespace {

enum Tag : int { kTask = 1, kStop = 2, kPart = 3, kError = 4, kBye = 5 };
// Batches a worker holds: the one it fits and two more. Rank 0 refills a worker only
// between the batches it fits itself, and batches differ in cost: with one batch in
// reserve a worker ran dry while rank 0 fitted a long one (measured: 2 ranks at 1.66x of
// one core with 2 held, 1.84x with 3, 1.80x with 4 on 90 batches; the more held, the
// longer the tail, where rank 0 cannot take a worker's batches back).
constexpr std::size_t kDepth = 3;

void check(int rc, const char* what) {
  if (rc != MPI_SUCCESS) throw Error(std::string("MPI call ") + what + " failed");
}

// Waits for a message without spinning a core: MPI's blocking probe busy-polls, which
// would take the core a co-located rank is fitting on.
MPI_Status wait_message(int source, int tag) {
  MPI_Status st;
  for (int idle = 0;; ++idle) {
    int flag = 0;
    check(MPI_Iprobe(source, tag, MPI_COMM_WORLD, &flag, &st), "MPI_Iprobe");
    if (flag) return st;
    std::this_thread::sleep_for(std::chrono::microseconds(idle < 200 ? 50 : 1000));
  }
}

std::vector<std::uint8_t> receive(const MPI_Status& st) {
  int n = 0;
  check(MPI_Get_count(&st, MPI_BYTE, &n), "MPI_Get_count");
  std::vector<std::uint8_t> buf(std::size_t(std::max(n, 0)));
  check(MPI_Recv(buf.data(), n, MPI_BYTE, st.MPI_SOURCE, st.MPI_TAG, MPI_COMM_WORLD, MPI_STATUS_IGNORE), "MPI_Recv");
  return buf;
}

template <class T>
void put(std::vector<std::uint8_t>& out, T v) {
  const auto* p = reinterpret_cast<const std::uint8_t*>(&v);
  out.insert(out.end(), p, p + sizeof(T));
}
template <class T>
T get(const std::vector<std::uint8_t>& in, std::size_t& at) {
  if (at + sizeof(T) > in.size()) throw Error("MPI farm: malformed message");
  T v;
  std::memcpy(&v, in.data() + at, sizeof(T));
  at += sizeof(T);
  return v;
}

}  // namespace

// Rank 0's side: the farm run_sweep calls.
struct MpiFarm::Root : BatchFarm {
  int size = 1;
  std::size_t job = 0;
  FarmStats stats;
  FarmOptions options;

  void run(const std::vector<std::vector<SliceRef>>& batches, const std::string& map,
           const std::function<BatchPart(const std::vector<SliceRef>&)>& fit_here,
           const std::function<void(BatchPart&&)>& commit) override {
    std::deque<std::size_t> queue;
    for (std::size_t b = 0; b < batches.size(); ++b) queue.push_back(b);
    std::vector<std::deque<std::size_t>> held(static_cast<std::size_t>(size));
    std::size_t done = 0;
    auto refill = [&](int w) {
      while (held[std::size_t(w)].size() < kDepth && !queue.empty()) {
        const std::size_t b = queue.front();
        queue.pop_front();
        std::vector<std::uint8_t> msg;
        put<std::uint64_t>(msg, job);
        put<std::uint64_t>(msg, map == "equal_area" ? 1 : 0);
        put<std::uint64_t>(msg, batches[b].size());
        for (const SliceRef& r : batches[b]) {
          put<std::uint64_t>(msg, r.index);
          put<std::uint64_t>(msg, r.t_o);
          put<std::uint64_t>(msg, r.p_o);
        }
        check(MPI_Send(msg.data(), int(msg.size()), MPI_BYTE, w, kTask, MPI_COMM_WORLD), "MPI_Send");
        stats.task_bytes += msg.size();
        held[std::size_t(w)].push_back(b);
      }
    };
    auto handle = [&](const MPI_Status& st) {
      const std::vector<std::uint8_t> msg = receive(st);
      const int w = st.MPI_SOURCE;
      if (st.MPI_TAG == kError)
        throw Error("rank " + std::to_string(w) + ": " + std::string(msg.begin(), msg.end()));
      if (st.MPI_TAG != kPart || held[std::size_t(w)].empty())
        throw Error("MPI farm: unexpected message from rank " + std::to_string(w));
      const auto t0 = std::chrono::steady_clock::now();
      const std::size_t b = held[std::size_t(w)].front();
      held[std::size_t(w)].pop_front();
      std::size_t at = 0;
      stats.compute_seconds += get<double>(msg, at);
      BatchPart part = decode_part(msg.data() + at, msg.size() - at);
      if (part.slice_index.size() != batches[b].size() || part.slice_index.front() != batches[b].front().index)
        throw Error("MPI farm: rank " + std::to_string(w) + " returned another batch than it was given");
      stats.part_bytes += msg.size();
      ++stats.batches;
      commit(std::move(part));
      stats.commit_seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      ++done;
      refill(w);
    };
    for (int w = 1; w < size; ++w) refill(w);
    while (done < batches.size()) {
      bool got = false;
      for (;;) {
        int flag = 0;
        MPI_Status st;
        check(MPI_Iprobe(MPI_ANY_SOURCE, MPI_ANY_TAG, MPI_COMM_WORLD, &flag, &st), "MPI_Iprobe");
        if (!flag) break;
        handle(st);
        got = true;
      }
      if (options.root_fits && !queue.empty()) {  // every worker holds kDepth batches: fit one here
        const std::size_t b = queue.front();
        queue.pop_front();
        const auto t0 = std::chrono::steady_clock::now();
        BatchPart part = fit_here(batches[b]);
        stats.compute_seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        ++stats.batches;
        ++stats.local_batches;
        const auto t1 = std::chrono::steady_clock::now();
        commit(std::move(part));
        stats.commit_seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();
        ++done;
      } else if (!got && done < batches.size()) {
        handle(wait_message(MPI_ANY_SOURCE, MPI_ANY_TAG));
      }
    }
    if (stats.batches == 0) return;
    const double n = double(stats.batches), remote = double(std::max<std::size_t>(stats.batches - stats.local_batches, 1));
    char line[256];
    std::snprintf(line, sizeof line,
                  "mpi: %d ranks, %zu batches (%zu fitted by rank 0); per remote batch %.0f B out, %.0f B back; "
                  "%.3f s of fitting and %.4f s of committing per batch",
                  size, stats.batches, stats.local_batches, double(stats.task_bytes) / remote,
                  double(stats.part_bytes) / remote, stats.compute_seconds / n, stats.commit_seconds / n);
    log_line(line);
    if (!options.stats_path.empty()) {
      if (std::FILE* f = std::fopen(options.stats_path.c_str(), "a")) {
        std::fprintf(f, "%d,%zu,%zu,%llu,%llu,%.6f,%.6f\n", size, stats.batches, stats.local_batches,
                     static_cast<unsigned long long>(stats.task_bytes), static_cast<unsigned long long>(stats.part_bytes),
                     stats.compute_seconds, stats.commit_seconds);
        std::fclose(f);
      }
    }
  }
};

MpiFarm::MpiFarm(const FarmOptions& options) {
  if (!options.launched) return;
  int already = 0;
  MPI_Initialized(&already);
  if (!already) {
    check(MPI_Init(nullptr, nullptr), "MPI_Init");
    initialized_ = true;
  }
  MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
  MPI_Comm_size(MPI_COMM_WORLD, &size_);
  if (size_ < 2) return;
  // Bit-identical results need one build on every rank: compare the executables.
  const std::uint64_t mine = hash_file("/proc/self/exe");
  std::vector<std::uint64_t> all(std::size_t(size_), 0);
  check(MPI_Allgather(&mine, 1, MPI_UINT64_T, all.data(), 1, MPI_UINT64_T, MPI_COMM_WORLD), "MPI_Allgather");
  for (int r = 1; r < size_; ++r)
    if (all[std::size_t(r)] != all[0]) {
      MPI_Finalize();  // every rank sees the same mismatch and throws: no one waits
      initialized_ = false;
      throw ConfigError("rank " + std::to_string(r) + " runs another bsdfmix executable than rank 0 (" +
                        hex64(all[std::size_t(r)]) + " vs " + hex64(all[0]) +
                        "): every rank must run the same build");
    }
  if (rank_ == 0) {
    root_ = std::make_unique<Root>();
    root_->size = size_;
    root_->options = options;
  } else {
    Progress::set_enabled(false);  // rank 0 reports progress for the job
  }
}

MpiFarm::~MpiFarm() {
  if (!initialized_) return;
  try {
    if (active() && !stopped_) {
      if (rank_ == 0) {
        for (int w = 1; w < size_; ++w) MPI_Send(nullptr, 0, MPI_BYTE, w, kStop, MPI_COMM_WORLD);
        // Drain whatever workers still send (parts of an aborted job) until each says bye.
        for (int byes = 0; byes < size_ - 1;) {
          const MPI_Status st = wait_message(MPI_ANY_SOURCE, MPI_ANY_TAG);
          receive(st);
          if (st.MPI_TAG == kBye) ++byes;
        }
      } else {  // a worker that never served (an error before): wait for stop, answer bye
        for (;;) {
          const MPI_Status st = wait_message(0, MPI_ANY_TAG);
          receive(st);
          if (st.MPI_TAG == kStop) break;
        }
        MPI_Send(nullptr, 0, MPI_BYTE, 0, kBye, MPI_COMM_WORLD);
      }
    }
  } catch (...) {
  }
  MPI_Finalize();
}

BatchFarm* MpiFarm::batch_farm() const { return root_.get(); }

void MpiFarm::set_job(std::size_t job) {
  if (root_) root_->job = job;
}

const FarmStats& MpiFarm::stats() const {
  static const FarmStats none;
  return root_ ? root_->stats : none;
}

void MpiFarm::serve(const std::vector<FarmJob>& jobs, const std::string& device_selector, const EngineOptions& engine) {
  if (!worker()) return;
  std::unique_ptr<BatchWorker> fitter;
  std::size_t fitter_job = SIZE_MAX;
  std::vector<std::uint8_t> out;  // the part in flight (kept alive until its send completes)
  MPI_Request pending = MPI_REQUEST_NULL;
  std::string failure;
  // Set up the first job's devices and kernels while rank 0 sets up its own.
  if (!jobs.empty() && jobs[0].table_ready) try {
      fitter = std::make_unique<BatchWorker>(jobs[0].table, jobs[0].fit, device_selector, engine);
      fitter_job = 0;
    } catch (const std::exception&) {
      fitter.reset();  // tried again, and reported, at the first batch
    }
  for (;;) {
    const MPI_Status st = wait_message(0, MPI_ANY_TAG);
    const std::vector<std::uint8_t> msg = receive(st);
    if (st.MPI_TAG == kStop) break;
    if (st.MPI_TAG != kTask || !failure.empty()) continue;  // after a failure: wait for stop
    int stop_pending = 0;
    MPI_Status ignored;
    MPI_Iprobe(0, kStop, MPI_COMM_WORLD, &stop_pending, &ignored);
    if (stop_pending) continue;  // rank 0 gave up on the job: skip the batches still queued
    try {
      std::size_t at = 0;
      const auto job = std::size_t(get<std::uint64_t>(msg, at));
      const std::string map = get<std::uint64_t>(msg, at) == 1 ? "equal_area" : "theta_phi";
      const auto n = std::size_t(get<std::uint64_t>(msg, at));
      if (job >= jobs.size()) throw Error("MPI farm: job " + std::to_string(job) + " unknown to this rank");
      std::vector<SliceRef> batch(n);
      for (SliceRef& r : batch) {
        r.index = std::size_t(get<std::uint64_t>(msg, at));
        r.t_o = std::size_t(get<std::uint64_t>(msg, at));
        r.p_o = std::size_t(get<std::uint64_t>(msg, at));
      }
      if (job != fitter_job) {
        fitter.reset();
        fitter = std::make_unique<BatchWorker>(jobs[job].table, jobs[job].fit, device_selector, engine);
        fitter_job = job;
      }
      const auto t0 = std::chrono::steady_clock::now();
      const BatchPart part = fitter->fit(batch, map);
      const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      check(MPI_Wait(&pending, MPI_STATUS_IGNORE), "MPI_Wait");
      out.clear();
      put<double>(out, seconds);
      const std::vector<std::uint8_t> bytes = encode_part(part);
      out.insert(out.end(), bytes.begin(), bytes.end());
      check(MPI_Isend(out.data(), int(out.size()), MPI_BYTE, 0, kPart, MPI_COMM_WORLD, &pending), "MPI_Isend");
    } catch (const std::exception& e) {
      failure = e.what();
      check(MPI_Wait(&pending, MPI_STATUS_IGNORE), "MPI_Wait");
      MPI_Send(failure.data(), int(failure.size()), MPI_BYTE, 0, kError, MPI_COMM_WORLD);
    }
  }
  MPI_Wait(&pending, MPI_STATUS_IGNORE);
  MPI_Send(nullptr, 0, MPI_BYTE, 0, kBye, MPI_COMM_WORLD);
  stopped_ = true;
  if (!failure.empty()) throw Error("rank " + std::to_string(rank_) + ": " + failure);
}

}  // namespace bsdfmix::scale
