// Peer EM timing: full-covariance 2D GMM with Armadillo's gmm_full.
//
// Usage: bsdfmix_peer_armadillo --data FILE --n N --k K --iterations I --seed S [--verbose]
//
// Prints one CSV line on stdout:
//     armadillo,K,N,I,seconds_per_iteration
// Exit status: 0 success, 1 any error (the target is only built where
// Armadillo is found, so "not installed" (3) cannot occur at run time).
//
// gmm_full has no sample weights: the fit runs unweighted on the same N
// points (theta, phi), zero-weight cells included, in double precision.
//
// Initialisation (untimed): arma_rng::set_seed(S), then
// learn(data, K, maha_dist, random_spread, km_iter=0, em_iter=0, 1e-10).
// Timed: learn(data, K, maha_dist, keep_existing, km_iter=0, em_iter=I, 1e-10),
// i.e. I EM iterations and no initialisation.  Each Armadillo EM iteration
// is one fused pass (E-step, accumulation, M-step, variance-floor fix-up).
// Armadillo stops early only when the average log-likelihood changes by at
// most machine epsilon; the iterations are counted from its progress output
// (print_mode, written into a string, not to stdout) and learn(keep_existing)
// is called again until exactly I iterations have run.
//
// Threading: Armadillo parallelises gmm_full over point chunks with OpenMP
// when compiled with OpenMP; omp_set_num_threads(1) forces one chunk and one
// thread (Armadillo's progress output reports "n_threads: 1", checked).

#include <armadillo>

#include <cerrno>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iostream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#ifdef _OPENMP
#include <omp.h>
#endif

namespace {

const char* const kImpl = "armadillo";

[[noreturn]] void fail(const std::string& msg, int code = 1) {
  std::string one = msg;
  for (char& c : one)
    if (c == '\n' || c == '\r') c = ' ';
  std::fprintf(stderr, "%s: %s\n", kImpl, one.c_str());
  std::exit(code);
}

long long parse_int(const char* flag, const char* text) {
  errno = 0;
  char* end = nullptr;
  const long long v = std::strtoll(text, &end, 10);
  if (errno != 0 || end == text || *end != '\0')
    fail(std::string("usage error: ") + flag + " expects an integer, got '" + text + "'");
  return v;
}

struct Args {
  std::string data;
  long long n = -1, k = -1, iterations = -1, seed = -1;
  bool verbose = false;
};

Args parse_args(int argc, char** argv) {
  Args a;
  bool have_seed = false;
  for (int i = 1; i < argc; ++i) {
    const std::string f = argv[i];
    if (f == "--verbose") {
      a.verbose = true;
      continue;
    }
    if (f != "--data" && f != "--n" && f != "--k" && f != "--iterations" && f != "--seed")
      fail("usage error: unknown argument '" + f + "'");
    if (i + 1 >= argc) fail("usage error: " + f + " needs a value");
    const char* v = argv[++i];
    if (f == "--data") a.data = v;
    else if (f == "--n") a.n = parse_int("--n", v);
    else if (f == "--k") a.k = parse_int("--k", v);
    else if (f == "--iterations") a.iterations = parse_int("--iterations", v);
    else { a.seed = parse_int("--seed", v); have_seed = true; }
  }
  if (a.data.empty() || a.n < 0 || a.k < 0 || a.iterations < 0 || !have_seed)
    fail("usage error: required: --data FILE --n N --k K --iterations I --seed S");
  if (a.n <= 0) fail("--n must be positive");
  if (a.k < 1 || a.k > a.n) fail("--k must be in [1, n]");
  if (a.iterations <= 0) fail("--iterations must be positive");
  if (a.seed < 0) fail("--seed must be non-negative");
  return a;
}

// Count "EM: iteration:" lines in Armadillo's progress output; also check its
// reported thread count.
long long count_em_iterations(const std::string& log, bool* single_thread) {
  long long count = 0;
  std::istringstream in(log);
  std::string line;
  while (std::getline(in, line)) {
    if (line.find("EM: iteration:") != std::string::npos) ++count;
    const auto p = line.find("EM: n_threads:");
    if (p != std::string::npos && std::atoll(line.c_str() + p + 14) != 1) *single_thread = false;
  }
  return count;
}

}  // namespace

int main(int argc, char** argv) {
  const Args args = parse_args(argc, argv);

#ifdef _OPENMP
  omp_set_num_threads(1);
#endif

  // Load the raw little-endian float32 triples (theta, phi, weight).
  std::ifstream file(args.data, std::ios::binary | std::ios::ate);
  if (!file) fail("cannot open " + args.data);
  const std::streamoff bytes = file.tellg();
  const std::streamoff expected = static_cast<std::streamoff>(args.n) * 3 * 4;
  if (bytes != expected)
    fail(args.data + " has " + std::to_string(bytes) + " bytes, expected 12 x " +
         std::to_string(args.n));
  file.seekg(0);
  std::vector<float> raw(static_cast<size_t>(args.n) * 3);
  if (!file.read(reinterpret_cast<char*>(raw.data()), expected)) fail("cannot read " + args.data);
  static_assert(sizeof(float) == 4, "float32 expected");
  {
    const uint16_t probe = 1;
    uint8_t first = 0;
    std::memcpy(&first, &probe, 1);
    if (first != 1) fail("big-endian hosts are not supported");
  }

  const arma::uword n = static_cast<arma::uword>(args.n);
  const arma::uword k = static_cast<arma::uword>(args.k);
  arma::mat data(2, n);
  for (arma::uword i = 0; i < n; ++i) {
    data(0, i) = raw[3 * i + 0];
    data(1, i) = raw[3 * i + 1];
  }
  if (!data.is_finite()) fail("data must be finite");

  const double var_floor = 1e-10;
  arma::gmm_full model;
  arma::arma_rng::set_seed(static_cast<arma::arma_rng::seed_type>(args.seed));
  if (!model.learn(data, k, arma::maha_dist, arma::random_spread, 0, 0, var_floor, false))
    fail("initialisation (random_spread) failed");

  // Timed EM. Progress output goes into a string buffer.
  std::ostringstream log;
  std::streambuf* const saved = std::cout.rdbuf(log.rdbuf());
  long long done = 0;
  int calls = 0;
  bool ok = true;
  const auto t0 = std::chrono::steady_clock::now();
  while (done < args.iterations) {
    const std::string::size_type before = log.str().size();
    ok = model.learn(data, k, arma::maha_dist, arma::keep_existing, 0,
                     static_cast<arma::uword>(args.iterations - done), var_floor, true);
    ++calls;
    if (!ok) break;
    bool single = true;
    const long long ran = count_em_iterations(log.str().substr(before), &single);
    if (!single) {
      ok = false;
      break;
    }
    if (ran <= 0) {
      ok = false;
      break;
    }
    done += ran;
  }
  const auto t1 = std::chrono::steady_clock::now();
  std::cout.rdbuf(saved);

  if (!ok) {
    bool single = true;
    count_em_iterations(log.str(), &single);
    if (!single) fail("gmm_full used more than one thread");
    fail("EM failed after " + std::to_string(done) + " iterations");
  }
  if (done != args.iterations)
    fail("EM ran " + std::to_string(done) + " iterations, expected " +
         std::to_string(args.iterations));

  const double seconds = std::chrono::duration<double>(t1 - t0).count();
  const double per_iter = seconds / static_cast<double>(args.iterations);

  if (args.verbose) {
    std::fprintf(stderr,
                 "%s %s: %lld EM iterations in %d learn() call(s), %.6f s; "
                 "avg log-likelihood %.6f\n",
                 kImpl, arma::arma_version::as_string().c_str(), done, calls, seconds,
                 model.avg_log_p(data));
  }
  std::printf("%s,%lld,%lld,%lld,%.9g\n", kImpl, args.k, args.n, args.iterations, per_iter);
  return 0;
}
