// The peer EM programs `bsdfmix bench em` times beside bsdfmix (bench/peers/, protocol
// in bench/peers/README.md): each runs as its own process on one slice written to a
// file, and prints its timing as its last line.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "fit/slices.hpp"

namespace bsdfmix::bench {

// What a peer prints: impl,k,cells,iterations,seconds_per_iteration.
struct PeerTiming {
  std::string impl;
  int k = 0;
  std::size_t cells = 0;
  int iterations = 0;
  double seconds_per_iteration = 0;
};

struct Peer {
  std::string name;     // the benchmark row
  std::string program;  // its path
  bool python = false;  // run by /usr/bin/python3
  std::string build;    // how it was compiled (the CSV's `build`)
  std::string command;  // the command line that times it
  PeerTiming best;      // its fastest run so far
  int reps = 0;         // its runs so far
  bool failed = false;  // dropped after a failed run
};

// The peers found (a missing program is skipped with a note), each with the command
// line that fits the slice in `data` (`cells` cells) with K `k`, `iterations`
// iterations and `seed`; with `quiet` their stderr is discarded.
std::vector<Peer> find_peers(const std::string& data, std::size_t cells, int k, int iterations, std::uint64_t seed,
                             bool quiet);

// Writes one slice as float32 (theta, phi, weight) triples, the peers' input; weights
// scaled to mean 1.
void write_peer_data(const std::string& path, const SliceGrid& grid, const std::vector<double>& w);

// Runs one peer's command; false (with a note) when it is missing, fails or prints an
// unreadable line.
bool run_peer(const Peer& peer, PeerTiming& timing);

// A fresh temporary file in /tmp, removed when this goes.
class TempFile {
 public:
  TempFile();
  ~TempFile();
  TempFile(const TempFile&) = delete;
  TempFile& operator=(const TempFile&) = delete;
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

}  // namespace bsdfmix::bench
