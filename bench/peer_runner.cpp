// The peer EM programs of `bsdfmix bench em`: found, fed and run as processes.
#include "bench/peer_runner.hpp"

#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <sstream>

#include "core/error.hpp"
#include "core/progress.hpp"

namespace bsdfmix::bench {

namespace {

// How the Armadillo peers were compiled: set by bench/peers/CMakeLists.txt.
#ifdef BSDFMIX_PEER_ARMADILLO_BUILD
const char* const kArmadilloBuild = BSDFMIX_PEER_ARMADILLO_BUILD;
#else
const char* const kArmadilloBuild = "unknown";
#endif
#ifdef BSDFMIX_PEER_ARMADILLO_GENERIC_BUILD
const char* const kArmadilloGenericBuild = BSDFMIX_PEER_ARMADILLO_GENERIC_BUILD;
#else
const char* const kArmadilloGenericBuild = "unknown";
#endif

std::string exe_dir() {
  char buf[4096];
  const ssize_t n = ::readlink("/proc/self/exe", buf, sizeof buf - 1);
  if (n <= 0) return ".";
  std::string p(buf, static_cast<std::size_t>(n));
  const auto slash = p.rfind('/');
  return slash == std::string::npos ? "." : p.substr(0, slash);
}

std::string shell_quote(const std::string& s) {
  std::string out = "'";
  for (char c : s) {
    if (c == '\'') out += "'\\''";
    else out += c;
  }
  return out + "'";
}

bool file_exists(const std::string& p) { return ::access(p.c_str(), F_OK) == 0; }

}  // namespace

std::vector<Peer> find_peers(const std::string& data, std::size_t cells, int k, int iterations, std::uint64_t seed,
                             bool quiet) {
  const std::string args = " --data " + shell_quote(data) + " --n " + std::to_string(cells) + " --k " +
                           std::to_string(k) + " --iterations " + std::to_string(iterations) + " --seed " +
                           std::to_string(seed);
  const std::string src = BSDFMIX_SOURCE_DIR;
  const std::string python_build = "prebuilt python3 packages (not rebuilt); BLAS/OpenMP pools pinned to 1 thread";
  const std::vector<Peer> all = {
      {"pomegranate", src + "/bench/peers/em_pomegranate.py", true, python_build, "", {}, 0, false},
      {"scikit-learn", src + "/bench/peers/em_sklearn.py", true, python_build, "", {}, 0, false},
      {"armadillo", exe_dir() + "/bench/peers/bsdfmix_peer_armadillo", false, kArmadilloBuild, "", {}, 0, false},
      // The same program without -march=native (built where the flags differ).
      {"armadillo_generic", exe_dir() + "/bench/peers/bsdfmix_peer_armadillo_generic", false, kArmadilloGenericBuild,
       "", {}, 0, false},
  };
  std::vector<Peer> peers;
  for (Peer p : all) {
    if (!file_exists(p.program)) {
      log_line("bench: peer " + p.name + " not found (" + p.program + ")");
      continue;
    }
    p.command = (p.python ? std::string("/usr/bin/python3 ") : std::string()) + shell_quote(p.program) + args +
                (quiet ? " 2>/dev/null" : "");
    peers.push_back(p);
  }
  return peers;
}

void write_peer_data(const std::string& path, const SliceGrid& grid, const std::vector<double>& w) {
  std::ofstream f(path, std::ios::binary);
  if (!f) throw IoError("bench: cannot write peer data " + path);
  double total = 0;
  for (double v : w) total += v;
  const double scale = static_cast<double>(w.size()) / total;
  const std::size_t np = grid.phi.size();
  for (std::size_t i = 0; i < w.size(); ++i) {
    const float v[3] = {static_cast<float>(grid.theta[i / np]), static_cast<float>(grid.phi[i % np]),
                        static_cast<float>(w[i] * scale)};
    f.write(reinterpret_cast<const char*>(v), sizeof v);
  }
  if (!f) throw IoError("bench: cannot write peer data " + path);
}

bool run_peer(const Peer& peer, PeerTiming& timing) {
  const std::string& name = peer.name;
  FILE* pipe = ::popen(peer.command.c_str(), "r");
  if (!pipe) {
    log_line("bench: cannot start peer " + name);
    return false;
  }
  std::string out;
  char buf[512];
  while (std::fgets(buf, sizeof buf, pipe)) out += buf;
  const int status = ::pclose(pipe);
  const int code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  if (code == 3) {
    log_line("bench: peer " + name + " skipped: its library is not installed");
    return false;
  }
  if (code != 0) {
    log_line("bench: peer " + name + " failed with exit code " + std::to_string(code));
    return false;
  }
  std::string last, line;
  std::istringstream ss(out);
  while (std::getline(ss, line))
    if (!line.empty()) last = line;
  std::vector<std::string> f;
  std::istringstream ls(last);
  std::string field;
  while (std::getline(ls, field, ',')) f.push_back(field);
  try {
    if (f.size() != 5) throw std::invalid_argument("fields");
    timing.impl = f[0];
    timing.k = std::stoi(f[1]);
    timing.cells = std::stoul(f[2]);
    timing.iterations = std::stoi(f[3]);
    timing.seconds_per_iteration = std::stod(f[4]);
    if (!(timing.seconds_per_iteration > 0)) throw std::invalid_argument("time");
  } catch (const std::exception&) {
    log_line("bench: peer " + name + " printed an unreadable line: '" + last + "'");
    return false;
  }
  return true;
}

TempFile::TempFile() {
  char tmpl[] = "/tmp/bsdfmix_bench_XXXXXX";
  const int fd = ::mkstemp(tmpl);
  if (fd < 0) throw IoError("bench: cannot create a temporary file in /tmp");
  ::close(fd);
  path_ = tmpl;
}

TempFile::~TempFile() { ::unlink(path_.c_str()); }

}  // namespace bsdfmix::bench
