// `bsdfmix bench em`, the EM throughput benchmark (bench/README.md): bsdfmix's EM
// engine on synthetic 90 x 180 fiber slices, against the CPU reference and the peer
// programs of bench/peers/, with the machine's measured FMA peak; a CSV and a table.
#pragma once

#include <cstdint>
#include <string>

namespace bsdfmix::bench {

struct EmBenchOptions {
  int k = 50;
  std::string csv;
  int iterations = 20;
  int slices = 64;
  int queues = 1;
  int repeat = 3;
  std::string precision = "auto";
  bool pool_log = false;  // print every batch run of the work queues (device/batch_pool.hpp)
  bool peers = true;
  bool reference = true;
  std::uint64_t seed = 1;
};

// Runs the benchmark on the devices of `device_selector`, writes o.csv and prints the
// table; `quiet`: no round lines, peers' stderr discarded. Throws ConfigError on bad
// options, Error when a timed fit stopped early.
void bench_em(const EmBenchOptions& o, const std::string& device_selector, bool quiet);

}  // namespace bsdfmix::bench
