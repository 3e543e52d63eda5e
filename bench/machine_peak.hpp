// What `bsdfmix bench em` records about the machine it ran on: the CPU model, the
// number of logical CPUs and a measured single-precision FMA peak.
#pragma once

#include <string>

namespace bsdfmix::bench {

// "model name" of the first processor in /proc/cpuinfo ("unknown" if absent).
std::string cpu_model_name();

// Online logical CPUs (sysconf(_SC_NPROCESSORS_ONLN)), at least 1.
int logical_cpus();

// The 1-minute load average of /proc/loadavg (-1 if unreadable): how busy the
// machine was with other work when a benchmark started.
double load_average_1min();

struct FmaPeak {
  double flops_per_s = 0;  // 0: not measured (no x86 vector FMA path)
  std::string isa;         // "avx512f", "avx2+fma", or why not measured
  int threads = 0;
  int chains = 0;          // independent FMA chains per thread
};

// Measures the machine's single-precision FMA peak: `threads` threads at once, each
// running independent chains of packed FMAs (acc = acc * a + b) for about `seconds`,
// with AVX-512 and with AVX2 where the CPU has them; an FMA counts as 2 flops per
// lane. Each thread's rate is its flops over its own CPU time (time descheduled on a
// shared machine is not counted); the peak is the sum over the threads, best of
// `repeat` per ISA, the faster ISA kept.
FmaPeak measure_fma_peak(int threads, int repeat, double seconds = 0.25);

}  // namespace bsdfmix::bench
