// Machine description and FMA peak microbenchmark of `bsdfmix bench em` and the render benchmark.
#include "bench/machine_peak.hpp"

#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <fstream>
#include <thread>
#include <vector>

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#define BSDFMIX_X86 1
#else
#define BSDFMIX_X86 0
#endif

namespace bsdfmix::bench {

std::string cpu_model_name() {
  std::ifstream f("/proc/cpuinfo");
  std::string line;
  while (std::getline(f, line)) {
    if (line.rfind("model name", 0) != 0) continue;
    const auto colon = line.find(':');
    if (colon == std::string::npos) break;
    std::string v = line.substr(colon + 1);
    const auto b = v.find_first_not_of(" \t");
    const auto e = v.find_last_not_of(" \t\r");
    return b == std::string::npos ? "unknown" : v.substr(b, e - b + 1);
  }
  return "unknown";
}

int logical_cpus() {
  const long n = ::sysconf(_SC_NPROCESSORS_ONLN);
  return n > 0 ? static_cast<int>(n) : 1;
}

double load_average_1min() {
  std::ifstream f("/proc/loadavg");
  double v = -1;
  if (!(f >> v)) return -1;
  return v;
}

namespace {

// Each kernel runs `iters` rounds of C independent packed FMA chains and returns a
// value depending on every chain (so that nothing is optimised away). acc * a + b
// with a just below 1 stays near 1: no overflow, no denormals.
#if BSDFMIX_X86
#define BSDFMIX_CHAINS_16(X) X(0) X(1) X(2) X(3) X(4) X(5) X(6) X(7) X(8) X(9) X(10) X(11) X(12) X(13) X(14) X(15)
#define BSDFMIX_CHAINS_12(X) X(0) X(1) X(2) X(3) X(4) X(5) X(6) X(7) X(8) X(9) X(10) X(11)

__attribute__((target("avx512f"))) float fma_avx512(long iters) {
  const __m512 a = _mm512_set1_ps(0.9999999f), b = _mm512_set1_ps(1e-7f);
#define DECL(i) __m512 c##i = _mm512_set1_ps(1.0f + (i) * 1e-3f);
#define STEP(i) c##i = _mm512_fmadd_ps(c##i, a, b);
#define SUM(i) s = _mm512_add_ps(s, c##i);
  BSDFMIX_CHAINS_16(DECL)
  for (long it = 0; it < iters; ++it) {
    BSDFMIX_CHAINS_16(STEP)
  }
  __m512 s = _mm512_setzero_ps();
  BSDFMIX_CHAINS_16(SUM)
  alignas(64) float out[16];
  _mm512_store_ps(out, s);
  return out[0];
#undef DECL
#undef STEP
#undef SUM
}

// 12 chains: with a and b, 14 of the 16 ymm registers (no spills).
__attribute__((target("avx2,fma"))) float fma_avx2(long iters) {
  const __m256 a = _mm256_set1_ps(0.9999999f), b = _mm256_set1_ps(1e-7f);
#define DECL(i) __m256 c##i = _mm256_set1_ps(1.0f + (i) * 1e-3f);
#define STEP(i) c##i = _mm256_fmadd_ps(c##i, a, b);
#define SUM(i) s = _mm256_add_ps(s, c##i);
  BSDFMIX_CHAINS_12(DECL)
  for (long it = 0; it < iters; ++it) {
    BSDFMIX_CHAINS_12(STEP)
  }
  __m256 s = _mm256_setzero_ps();
  BSDFMIX_CHAINS_12(SUM)
  alignas(32) float out[8];
  _mm256_store_ps(out, s);
  return out[0];
#undef DECL
#undef STEP
#undef SUM
}
#endif

struct Isa {
  const char* name;
  float (*run)(long);
  int lanes, chains;
};

double thread_cpu_seconds() {
  timespec ts{};
  ::clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

// Flops per second of `threads` threads running `isa` together for about `seconds`:
// the sum over the threads of each one's flops over its own CPU time, so that time
// a thread spends descheduled (the machine may be shared) does not lower the peak.
// Other work on the machine thus does not lower it; threads that did not all run at
// once can overstate it, which only understates a percentage of it.
double time_isa(const Isa& isa, int threads, double seconds) {
  using clock = std::chrono::steady_clock;
  // Calibrate the iteration count on one thread.
  long iters = 1 << 16;
  for (;;) {
    const auto t0 = clock::now();
    volatile float sink = isa.run(iters);
    (void)sink;
    const double t = std::chrono::duration<double>(clock::now() - t0).count();
    if (t > 0.02 || iters > (1L << 40)) {
      iters = std::max(1L, static_cast<long>(iters * seconds / std::max(t, 1e-9)));
      break;
    }
    iters *= 4;
  }
  std::atomic<int> ready{0};
  std::atomic<bool> go{false};
  std::vector<std::thread> pool;
  std::vector<float> sinks(static_cast<std::size_t>(threads));
  std::vector<double> cpu(static_cast<std::size_t>(threads));
  for (int i = 0; i < threads; ++i)
    pool.emplace_back([&, i] {
      ready.fetch_add(1);
      while (!go.load(std::memory_order_acquire)) {
      }
      const double c0 = thread_cpu_seconds();
      sinks[static_cast<std::size_t>(i)] = isa.run(iters);
      cpu[static_cast<std::size_t>(i)] = thread_cpu_seconds() - c0;
    });
  while (ready.load() != threads) {
  }
  go.store(true, std::memory_order_release);
  for (auto& t : pool) t.join();
  const double flops_per_thread = static_cast<double>(iters) * isa.chains * isa.lanes * 2.0;
  double total = 0;
  for (double c : cpu) total += flops_per_thread / std::max(c, 1e-9);
  return total;
}

}  // namespace

FmaPeak measure_fma_peak(int threads, int repeat, double seconds) {
  FmaPeak best;
  best.threads = threads;
#if BSDFMIX_X86
  std::vector<Isa> isas;
  __builtin_cpu_init();
  if (__builtin_cpu_supports("avx512f")) isas.push_back({"avx512f", fma_avx512, 16, 16});
  if (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma"))
    isas.push_back({"avx2+fma", fma_avx2, 8, 12});
  if (isas.empty()) {
    best.isa = "not measured (no AVX2/FMA or AVX-512 on this CPU)";
    return best;
  }
  // Both ISAs where both exist: some CPUs run 512-bit FMAs at half rate.
  for (const auto& isa : isas)
    for (int rep = 0; rep < std::max(1, repeat); ++rep) {
      const double f = time_isa(isa, threads, seconds);
      if (f > best.flops_per_s) {
        best.flops_per_s = f;
        best.isa = isa.name;
        best.chains = isa.chains;
      }
    }
#else
  (void)repeat;
  (void)seconds;
  best.isa = "not measured (no x86 FMA path for this CPU)";
#endif
  return best;
}

}  // namespace bsdfmix::bench
