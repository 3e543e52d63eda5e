// Past one machine: a batch part survives its trip through bytes exactly; `mpirun -n 2`
// and `-n 3` fits write the same mixture file, bit for bit, as a 1-process fit (also
// when a stopped MPI run is resumed); a catalog fits its tables into one mixture file
// each and writes its summary CSV. The MPI runs stay on this machine (shared memory).
// labels: scale fit
#include <catch2/catch.hpp>

#include <fcntl.h>
#include <sys/file.h>
#include <sys/wait.h>
#include <unistd.h>
#include <signal.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <regex>
#include <sstream>
#include <thread>

#include "core/error.hpp"
#include "io/mixture_file.hpp"
#include "io/table.hpp"
#include "scale/catalog.hpp"
#include "scale/part_codec.hpp"

using namespace bsdfmix;
namespace fs = std::filesystem;

namespace {

fs::path temp_dir() {
  const fs::path d = fs::temp_directory_path() / "bsdfmix_mpi_test";
  fs::create_directories(d);
  return d;
}

std::string slurp(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(f)), {});
}

struct Run {
  int code;
  std::string out, err;
};

// Runs `prefix bsdfmix args` through the shell; prefix is "" or an mpirun line.
Run run(const std::string& prefix, const std::string& args) {
  const fs::path out = temp_dir() / "out.txt", err = temp_dir() / "err.txt";
  const std::string cmd = prefix + std::string(BSDFMIX_BINARY) + " " + args + " >" + out.string() + " 2>" + err.string();
  const int status = std::system(cmd.c_str());
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, slurp(out), slurp(err)};
}

// mpirun on this machine only: shared memory between the ranks, root allowed (CI runs
// as root), more ranks than cores allowed.
std::string mpirun(int ranks) {
  setenv("OMPI_ALLOW_RUN_AS_ROOT", "1", 1);
  setenv("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1", 1);
  setenv("OMPI_MCA_rmaps_base_oversubscribe", "1", 1);
  return "mpirun -n " + std::to_string(ranks) + " --oversubscribe --bind-to none --mca btl self,vader ";
}

// A small fiber table with an rgb channel: two lobes per slice of two colours, moving
// with theta_o.
std::string small_table() {
  const std::string path = (temp_dir() / "small_table_rgb.h5").string();
  if (fs::exists(path)) return path;
  const std::size_t n_to = 12, nt = 16, np = 32;
  TableMeta m = make_grid(Domain::Fiber, n_to, 1, nt, np, true);
  m.source = R"({"model": "mpi test"})";
  m.rgb = true;
  TableWriter out(path, m);
  for (std::size_t t = 0; t < n_to; ++t) {
    std::vector<float> v, rgb;
    for (std::size_t i = 0; i < nt; ++i)
      for (std::size_t j = 0; j < np; ++j) {
        const double a = m.theta_i[i], b = m.phi_i[j], c = 0.1 * double(t);
        const double l1 = std::exp(-((a - c) * (a - c) + (b - 1.0) * (b - 1.0)) / 0.08);
        const double l2 = 0.5 * std::exp(-((a + c) * (a + c) + (b + 2.0) * (b + 2.0)) / 0.2);
        v.push_back(float(l1 + l2 + 0.01));
        rgb.insert(rgb.end(), {float(0.9 * l1 + 0.2 * l2 + 0.01), float(0.4 * l1 + 0.6 * l2 + 0.01),
                               float(0.1 * l1 + 0.9 * l2 + 0.01)});
      }
    out.write_slice(t, 0, v.data(), rgb.data());
  }
  out.commit();
  return path;
}

// A fit config of the small table writing to <stem>_*.
std::string fit_config(const std::string& stem) {
  const fs::path d = temp_dir();
  const std::string path = (d / (stem + ".yaml")).string();
  std::ofstream f(path);
  f << "table: " << small_table() << "\n"
    << "fit:\n  output: " << (d / (stem + "_mixture.h5")).string() << "\n  report: " << (d / (stem + "_fit.csv")).string()
    << "\n  search_report: " << (d / (stem + "_search.csv")).string()
    << "\n  k_min: 1\n  k_max: 4\n  restarts: 1\n  final_restarts: 2\n  iterations: 30\n  final_iterations: 60\n"
    << "  batch: 2\n";
  return path;
}

template <class T>
bool same_bits(const std::vector<T>& a, const std::vector<T>& b) {
  return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0);
}

void require_same_mixture(const std::string& a_path, const std::string& b_path) {
  const MixtureFile a = read_mixture_file(a_path), b = read_mixture_file(b_path);
  REQUIRE(a.slices() > 0);
  CHECK(a.slices() == b.slices());
  CHECK(a.kmax == b.kmax);
  CHECK(same_bits(a.k, b.k));
  CHECK(same_bits(a.weights, b.weights));
  CHECK(same_bits(a.means, b.means));
  CHECK(same_bits(a.covariances, b.covariances));
  CHECK(same_bits(a.l1_rel, b.l1_rel));
  CHECK(same_bits(a.loglik, b.loglik));
  CHECK(same_bits(a.scale, b.scale));
  CHECK(a.has_rgb() == b.has_rgb());
  CHECK(same_bits(a.rgb_scale, b.rgb_scale));
  CHECK(same_bits(a.rgb_copies, b.rgb_copies));
  CHECK(same_bits(a.theta_o, b.theta_o));
  CHECK(a.fit_settings == b.fit_settings);
}

// The farm's closing log line: batches in all and those rank 0 fitted itself.
std::pair<int, int> farm_batches(const std::string& err) {
  std::smatch m;
  const std::regex re(R"(mpi: (\d+) ranks, (\d+) batches \((\d+) fitted by rank 0\))");
  if (!std::regex_search(err, m, re)) return {-1, -1};
  return {std::stoi(m[2]), std::stoi(m[3])};
}

const std::string& reference_mixture() {
  static const std::string path = [] {
    const std::string cfg = fit_config("one");
    const Run r = run("", "fit " + cfg + " -q");
    INFO(r.err);
    REQUIRE(r.code == 0);
    const std::string out = (temp_dir() / "one_mixture.h5").string();
    REQUIRE(read_mixture_file(out).has_rgb());  // the small table's colour is fitted too
    return out;
  }();
  return path;
}

}  // namespace

TEST_CASE("a batch part survives its trip through bytes bit for bit", "[scale]") {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-3, 3);
  BatchPart p;
  p.mixture.domain = Domain::Hemisphere;
  p.mixture.azimuthal = false;
  p.mixture.table_source = R"({"model": "x"})";
  p.mixture.fit_settings = R"({"k_max": 3})";
  p.mixture.table_theta_o = {0.1, 0.2};
  p.mixture.table_phi_o = {0.0, 1.0, 2.0};
  for (std::size_t s = 0; s < 5; ++s) {
    const int k = 1 + int(s % 3);
    std::vector<double> w, mean, cov;
    for (int j = 0; j < k; ++j) {
      w.push_back(std::abs(u(rng)) + 0.1);
      mean.insert(mean.end(), {u(rng), u(rng)});
      cov.insert(cov.end(), {1.0 + std::abs(u(rng)), 0.1 * u(rng), 1.0 + std::abs(u(rng))});
    }
    std::vector<double> rgb;
    for (int j = 0; j < 3 * k; ++j) rgb.push_back(std::abs(u(rng)));
    std::vector<double> copies;  // colour copies on slices 1 and 3
    if (s % 2 == 1)
      for (int j = 0; j < 12 * k; ++j) copies.push_back(std::abs(u(rng)));
    p.mixture.add_slice(u(rng), u(rng), std::abs(u(rng)), u(rng), s == 4 ? 0.0 : std::abs(u(rng)), w, mean, cov, &rgb,
                        &copies);
    p.slice_index.push_back(100 + 3 * s);
  }
  p.mixture.loglik[2] = -0.0;  // the sign of zero survives too
  for (std::size_t s = 0; s < 5; ++s)
    p.report.push_back({p.slice_index[s], u(rng), u(rng), p.mixture.k[s], int(s) * 7, u(rng), std::abs(u(rng)),
                        std::abs(u(rng)), "cpu+gpu", s == 3 ? "failed: no usable fit; one moment-matched Gaussian stands in"
                                                            : "ok"});
  p.report[1].status = std::string("any bytes: ") + std::string(1, '\0') + "x,\n";
  p.report[2].loglik = -0.0;
  for (std::size_t s = 0; s < 5; ++s) {
    p.report[s].rgb_l1_rel = std::abs(u(rng));
    p.report[s].rgb_negative = 0.1 * std::abs(u(rng));
    p.report[s].defensive = 0.01 * double(s);
    p.report[s].max_weight = std::abs(u(rng));
    p.mixture.defensive[s] = 0.02 * double(s);
  }
  p.report[3].rgb_l1_rel = p.report[3].rgb_negative = std::numeric_limits<double>::quiet_NaN();  // a row without colour
  p.search.push_back({103, 2, 0, -1, 0.2, 0.208, true});
  p.search.push_back({103, 3, 1, u(rng), u(rng), u(rng), false});
  p.slices_hash = "0123456789abcdef";

  const std::vector<std::uint8_t> bytes = scale::encode_part(p);
  const BatchPart q = scale::decode_part(bytes.data(), bytes.size());
  CHECK(q.slice_index == p.slice_index);
  CHECK(q.mixture.domain == p.mixture.domain);
  CHECK(q.mixture.azimuthal == p.mixture.azimuthal);
  CHECK(q.mixture.table_source == p.mixture.table_source);
  CHECK(q.mixture.fit_settings == p.mixture.fit_settings);
  CHECK(same_bits(q.mixture.table_theta_o, p.mixture.table_theta_o));
  CHECK(same_bits(q.mixture.table_phi_o, p.mixture.table_phi_o));
  for (auto f : {&MixtureFile::theta_o, &MixtureFile::phi_o, &MixtureFile::scale, &MixtureFile::loglik,
                 &MixtureFile::l1_rel, &MixtureFile::defensive})
    CHECK(same_bits(q.mixture.*f, p.mixture.*f));
  CHECK(same_bits(q.mixture.k, p.mixture.k));
  CHECK(q.mixture.kmax == p.mixture.kmax);
  CHECK(same_bits(q.mixture.weights, p.mixture.weights));
  CHECK(same_bits(q.mixture.means, p.mixture.means));
  CHECK(same_bits(q.mixture.covariances, p.mixture.covariances));
  CHECK(q.mixture.has_rgb());
  CHECK(same_bits(q.mixture.rgb_scale, p.mixture.rgb_scale));
  CHECK(q.mixture.has_copies());
  CHECK(same_bits(q.mixture.rgb_copies, p.mixture.rgb_copies));
  CHECK(q.mixture.slice_copies(0).empty());
  CHECK(q.mixture.slice_copies(1).size() == 12 * std::size_t(q.mixture.k[1]));
  REQUIRE(q.report.size() == p.report.size());
  for (std::size_t i = 0; i < p.report.size(); ++i) {
    const ReportRow &a = q.report[i], &b = p.report[i];
    CHECK(a.slice == b.slice);
    CHECK(same_bits(std::vector<double>{a.theta_o, a.phi_o, a.loglik, a.l1_rel, a.seconds, a.rgb_l1_rel, a.rgb_negative,
                                        a.defensive, a.max_weight},
                    std::vector<double>{b.theta_o, b.phi_o, b.loglik, b.l1_rel, b.seconds, b.rgb_l1_rel, b.rgb_negative,
                                        b.defensive, b.max_weight}));
    CHECK(a.k == b.k);
    CHECK(a.iterations == b.iterations);
    CHECK(a.device == b.device);
    CHECK(a.status == b.status);
    CHECK(a.failed() == b.failed());
  }
  CHECK(q.report[3].failed());
  CHECK(std::isnan(q.report[3].rgb_l1_rel));
  CHECK(std::signbit(q.report[2].loglik));
  REQUIRE(q.search.size() == p.search.size());
  for (std::size_t i = 0; i < p.search.size(); ++i) {
    const SearchRow &a = q.search[i], &b = p.search[i];
    CHECK(a.slice == b.slice);
    CHECK(a.k == b.k);
    CHECK(a.restart == b.restart);
    CHECK(same_bits(std::vector<double>{a.loglik, a.l1_rel, a.score}, std::vector<double>{b.loglik, b.l1_rel, b.score}));
    CHECK(a.chosen == b.chosen);
  }
  CHECK(q.slices_hash == p.slices_hash);
  CHECK(std::signbit(q.mixture.loglik[2]));
  CHECK(scale::encode_part(q) == bytes);
  // A part of a table without rgb comes back without it.
  BatchPart grey = p;
  grey.mixture.rgb_scale.clear();
  grey.mixture.rgb_copies.clear();  // (copies without rgb_scale are refused: below)
  const std::vector<std::uint8_t> grey_bytes = scale::encode_part(grey);
  CHECK_FALSE(scale::decode_part(grey_bytes.data(), grey_bytes.size()).mixture.has_rgb());
  BatchPart torn = p;  // rgb_scale of the wrong length is refused
  torn.mixture.rgb_scale.pop_back();
  const std::vector<std::uint8_t> torn_bytes = scale::encode_part(torn);
  CHECK_THROWS_AS(scale::decode_part(torn_bytes.data(), torn_bytes.size()), InputError);
  BatchPart orphan = grey;  // colour copies without rgb_scale are refused
  orphan.mixture.rgb_copies = p.mixture.rgb_copies;
  const std::vector<std::uint8_t> orphan_bytes = scale::encode_part(orphan);
  CHECK_THROWS_AS(scale::decode_part(orphan_bytes.data(), orphan_bytes.size()), InputError);
  BatchPart torn_copies = p;  // and so are rgb_copies of the wrong length
  torn_copies.mixture.rgb_copies.pop_back();
  const std::vector<std::uint8_t> torn_copy_bytes = scale::encode_part(torn_copies);
  CHECK_THROWS_AS(scale::decode_part(torn_copy_bytes.data(), torn_copy_bytes.size()), InputError);

  // Truncated or padded bytes are refused, never half-read.
  for (std::size_t n : {std::size_t(0), std::size_t(7), bytes.size() / 2, bytes.size() - 1})
    CHECK_THROWS_AS(scale::decode_part(bytes.data(), n), InputError);
  std::vector<std::uint8_t> longer = bytes;
  longer.push_back(0);
  CHECK_THROWS_AS(scale::decode_part(longer.data(), longer.size()), InputError);
}

TEST_CASE("mpirun -n 2 and -n 3 fits equal the 1-process fit bit for bit", "[scale]") {
  const std::string one = reference_mixture();
  for (int ranks : {2, 3}) {
    INFO(ranks << " ranks");
    const std::string stem = "ranks" + std::to_string(ranks);
    const Run r = run(mpirun(ranks), "fit " + fit_config(stem));
    INFO(r.err);
    REQUIRE(r.code == 0);
    // 12 slices in batches of 2: 6 batches, some fitted by the workers.
    const auto [batches, by_root] = farm_batches(r.err);
    CHECK(batches == 6);
    CHECK(by_root >= 0);
    CHECK(by_root < batches);
    CHECK_FALSE(fs::exists(temp_dir() / (stem + "_mixture.h5.parts")));
    require_same_mixture(one, (temp_dir() / (stem + "_mixture.h5")).string());
    // rank 0 printed the summary, once, for all 12 slices
    REQUIRE(r.out.find("fit ") != std::string::npos);
    CHECK(r.out.find("fit ") == r.out.rfind("fit "));
    CHECK_THAT(r.out, Catch::Contains("slices           12 fitted"));
    CHECK(r.out.find("relative L1") == r.out.rfind("relative L1"));
  }
}

TEST_CASE("BSDFMIX_MPI_ROOT_FITS=0 keeps rank 0 to handing out; BSDFMIX_MPI_STATS appends the traffic", "[scale]") {
  const std::string one = reference_mixture();
  const fs::path stats = temp_dir() / "root_idle_stats.csv";
  fs::remove(stats);
  const std::string env = "BSDFMIX_MPI_ROOT_FITS=0 BSDFMIX_MPI_STATS=" + stats.string() + " ";
  const Run r = run(env + mpirun(2), "fit " + fit_config("root_idle"));
  INFO(r.err);
  REQUIRE(r.code == 0);
  const auto [batches, by_root] = farm_batches(r.err);
  CHECK(batches == 6);
  CHECK(by_root == 0);
  CHECK(slurp(stats).rfind("2,6,0,", 0) == 0);  // ranks, batches, fitted by rank 0, ...
  require_same_mixture(one, (temp_dir() / "root_idle_mixture.h5").string());
}

// fit.map auto on a hemisphere table: rank 0 probes, and the workers (rank 0 fits none
// here) fit in the map it chose, which only the task message tells them.
TEST_CASE("fit.map auto: the workers fit in the map rank 0's probe chose", "[scale]") {
  const fs::path d = temp_dir();
  const std::string table = (d / "auto_table.h5").string();
  if (!fs::exists(table)) {
    TableMeta m = make_grid(Domain::Hemisphere, 14, 1, 16, 32, true);
    m.source = R"({"model": "mpi auto test"})";
    std::vector<float> v;
    for (std::size_t t = 0; t < 14; ++t)  // a diffuse floor under a lobe: the disk wins
      for (double a : m.theta_i)
        for (double b : m.phi_i) {
          const double dt = a - 0.05 * double(t);
          v.push_back(float(0.3 + 3.0 * std::exp(-(dt * dt + b * b) / (2 * 0.15 * 0.15))));
        }
    write_table(table, m, v);
  }
  auto config = [&](const std::string& stem) {
    const std::string path = (d / (stem + ".yaml")).string();
    std::ofstream f(path);
    f << "table: " << table << "\nfit:\n  output: " << (d / (stem + "_mixture.h5")).string()
      << "\n  report: " << (d / (stem + "_fit.csv")).string() << "\n  search_report: " << (d / (stem + "_search.csv")).string()
      << "\n  k_min: 1\n  k_max: 3\n  restarts: 1\n  final_restarts: 2\n  iterations: 30\n  final_iterations: 60\n"
      << "  refine_evaluations: 30\n  batch: 2\n";
    return path;
  };
  Run r = run("", "fit " + config("auto_one") + " -q");
  INFO(r.err);
  REQUIRE(r.code == 0);
  const std::string one = (d / "auto_one_mixture.h5").string();
  REQUIRE(read_mixture_file(one).map == mix::Map::Disk);
  r = run("BSDFMIX_MPI_ROOT_FITS=0 " + mpirun(2), "fit " + config("auto_two"));
  INFO(r.err);
  REQUIRE(r.code == 0);
  CHECK_THAT(r.err, Catch::Contains("the equal-area disk, by a probe of 10 slice(s)"));
  CHECK(farm_batches(r.err).second == 0);
  require_same_mixture(one, (d / "auto_two_mixture.h5").string());
  CHECK(read_mixture_file((d / "auto_two_mixture.h5").string()).map == mix::Map::Disk);
}

TEST_CASE("a stopped 2-rank fit resumes to the 1-process file", "[scale]") {
  const std::string one = reference_mixture();
  const std::string cfg = fit_config("resumed");
  const std::string out = (temp_dir() / "resumed_mixture.h5").string();
  fs::remove(out);
  Run r = run(mpirun(2), "fit " + cfg + " -q --max-batches 2");
  INFO(r.err);
  REQUIRE(r.code == 0);
  CHECK_FALSE(fs::exists(out));
  CHECK(fs::exists(out + ".parts"));
  r = run(mpirun(2), "fit " + cfg);
  INFO(r.err);
  REQUIRE(r.code == 0);
  CHECK_THAT(r.err, Catch::Contains("resuming: 4 slice(s)"));
  require_same_mixture(one, out);
}

// The job is killed by events on disk, not by a clock: right after its first committed
// part is seen, with many batches still to fit.
TEST_CASE("a 2-rank fit killed with SIGKILL resumes to the 1-process file", "[scale]") {
  const fs::path d = temp_dir();
  const std::string table = (d / "kill_table.h5").string();
  const std::size_t n_to = 40, nt = 40, np = 80;
  TableMeta m = make_grid(Domain::Fiber, n_to, 1, nt, np, true);
  m.source = R"({"model": "mpi kill test"})";
  std::vector<float> v;
  for (std::size_t t = 0; t < n_to; ++t)
    for (std::size_t i = 0; i < nt; ++i)
      for (std::size_t j = 0; j < np; ++j) {
        const double a = m.theta_i[i], b = m.phi_i[j], c = 0.03 * double(t);
        v.push_back(float(std::exp(-((a - c) * (a - c) + (b - 1.0) * (b - 1.0)) / 0.02) +
                          0.5 * std::exp(-((a + c) * (a + c) + (b + 2.0) * (b + 2.0)) / 0.1) + 0.01));
      }
  write_table(table, m, v);
  auto config = [&](const std::string& stem) {
    const std::string path = (d / (stem + ".yaml")).string();
    std::ofstream(path) << "table: " << table << "\nfit:\n  output: " << (d / (stem + "_mixture.h5")).string()
                        << "\n  report: " << (d / (stem + "_fit.csv")).string()
                        << "\n  search_report: " << (d / (stem + "_search.csv")).string()
                        << "\n  k_max: 6\n  batch: 2\n";
    return path;
  };
  const std::string ref_cfg = config("kill_ref"), cfg = config("killed");
  const std::string out = (d / "killed_mixture.h5").string(), parts = out + ".parts";
  fs::remove(out);
  fs::remove_all(parts);
  Run r = run("", "fit -q " + ref_cfg);
  INFO(r.err);
  REQUIRE(r.code == 0);

  const std::string cmd = mpirun(2) + std::string(BSDFMIX_BINARY) + " fit -q " + cfg + " >/dev/null 2>&1";
  const pid_t pid = fork();
  if (pid == 0) {
    setsid();  // its own process group: mpirun and both ranks die together
    execl("/bin/sh", "sh", "-c", cmd.c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  auto committed = [&] {
    std::size_t n = 0;
    std::error_code ec;
    for (fs::directory_iterator it(parts, ec), end; !ec && it != end; it.increment(ec)) {
      const std::string name = it->path().filename().string();
      n += name.rfind("batch_", 0) == 0 && name.find(".partial-") == std::string::npos;
    }
    return n;
  };
  int status = 0;
  bool exited = false;
  while (!(exited = waitpid(pid, &status, WNOHANG) == pid) && committed() == 0)
    std::this_thread::sleep_for(std::chrono::microseconds(200));
  REQUIRE_FALSE(exited);  // 20 batches: the job cannot end within a poll of its first commit
  // The whole job at once, as a batch scheduler kills it: mpirun's group, and the ranks,
  // which mpirun starts in sessions of their own (found by their command line).
  kill(-pid, SIGKILL);
  std::vector<pid_t> ranks;
  for (const auto& e : fs::directory_iterator("/proc")) {
    const std::string name = e.path().filename().string();
    if (name.find_first_not_of("0123456789") != std::string::npos || std::stoi(name) == getpid()) continue;
    std::string cmdline = slurp(e.path() / "cmdline");
    std::replace(cmdline.begin(), cmdline.end(), '\0', ' ');
    if (cmdline.find(cfg) != std::string::npos && cmdline.find(BSDFMIX_BINARY) == 0) ranks.push_back(std::stoi(name));
  }
  for (pid_t rank : ranks) kill(rank, SIGKILL);
  waitpid(pid, &status, 0);
  for (pid_t rank : ranks)  // gone when /proc no longer lists it (or lists a zombie)
    while (fs::exists("/proc/" + std::to_string(rank)) &&
           slurp("/proc/" + std::to_string(rank) + "/stat").find(") Z") == std::string::npos)
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
  // A rank's main thread shows as a zombie while its other threads (device, MPI) still
  // tear down and keep its files open; the lock is free once the last of them is gone.
  const std::string lock_path = out + ".lock";
  auto lock_free = [&] {
    const int fd = ::open(lock_path.c_str(), O_RDWR | O_CLOEXEC);
    if (fd < 0) return true;
    const bool free = ::flock(fd, LOCK_EX | LOCK_NB) == 0;
    ::close(fd);
    return free;
  };
  while (!lock_free()) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  CHECK_FALSE(fs::exists(out));
  const std::size_t done = committed();
  REQUIRE(done >= 1);
  REQUIRE(done < n_to / 2);

  r = run("", "fit " + cfg);  // resumed without mpirun: the parts are the same either way
  INFO(r.err);
  REQUIRE(r.code == 0);
  CHECK_THAT(r.out, Catch::Contains("(" + std::to_string(2 * done) + " resumed from checkpoint"));
  require_same_mixture((d / "kill_ref_mixture.h5").string(), out);
}

TEST_CASE("without mpirun a fit makes no MPI call", "[scale]") {
  // A plain run prints no farm line and needs no launcher.
  const Run r = run("", "fit " + fit_config("plain"));
  INFO(r.err);
  REQUIRE(r.code == 0);
  CHECK(r.err.find("mpi:") == std::string::npos);
  require_same_mixture(reference_mixture(), (temp_dir() / "plain_mixture.h5").string());
}

TEST_CASE("a catalog fits every table into its own mixture file and writes the summary", "[scale]") {
  const fs::path d = temp_dir() / "catalog";
  fs::remove_all(d);
  fs::create_directories(d);
  const std::string cfg = (temp_dir() / "catalog.yaml").string();
  {
    std::ofstream f(cfg);
    f << "catalog:\n  dir: " << d.string() << "\n  presets: [silk, wool]\n"
      << "  generate: {theta_o: 4, theta_i: 12, phi_i: 24}\n"
      << "  fit: {k_min: 1, k_max: 3, restarts: 1, final_restarts: 1, iterations: 20, final_iterations: 40}\n"
      << "  tables:\n    - table: " << small_table() << "\n      name: small\n      fit: {k_max: 2}\n";
  }
  const scale::Catalog cat = scale::load_catalog(cfg);
  REQUIRE(cat.entries.size() == 3);
  CHECK(cat.entries[0].name == "silk");
  CHECK(cat.entries[2].config.fit->k_max == 2);
  CHECK(cat.entries[0].config.fit->k_max == 3);

  const Run r = run("", "catalog " + cfg + " -q");
  INFO(r.err);
  REQUIRE(r.code == 0);
  const std::string csv = slurp(d / "summary.csv");
  INFO(csv);
  CHECK(csv.rfind("table,slices,mean_k,l1_median,l1_p90,table_bytes,mixture_bytes,seconds\n", 0) == 0);
  CHECK(std::count(csv.begin(), csv.end(), '\n') == 4);
  CHECK_THAT(csv, Catch::Contains("\nsilk,4,"));
  CHECK_THAT(csv, Catch::Contains("\nwool,4,"));
  CHECK_THAT(csv, Catch::Contains("\nsmall,12,"));
  for (const char* n : {"silk", "wool", "small"}) {
    INFO(n);
    const MixtureFile m = read_mixture_file((d / (std::string(n) + "_mixture.h5")).string());
    CHECK(m.slices() == (std::string(n) == "small" ? 12u : 4u));
  }

  // The same catalog on 2 ranks: the same mixture files.
  const fs::path d2 = temp_dir() / "catalog2";
  fs::remove_all(d2);
  const std::string cfg2 = (temp_dir() / "catalog2.yaml").string();
  {
    std::string text = slurp(cfg);
    text.replace(text.find(d.string()), d.string().size(), d2.string());
    std::ofstream(cfg2) << text;
  }
  const Run r2 = run(mpirun(2), "catalog " + cfg2 + " -q");
  INFO(r2.err);
  REQUIRE(r2.code == 0);
  for (const char* n : {"silk", "wool", "small"}) {
    INFO(n);
    require_same_mixture((d / (std::string(n) + "_mixture.h5")).string(), (d2 / (std::string(n) + "_mixture.h5")).string());
  }
}

TEST_CASE("catalog errors name the key", "[scale]") {
  CHECK_THROWS_WITH(scale::parse_catalog("catalog:\n  presets: [silk]\n  colour: red\n", "c.yaml"),
                    Catch::Contains("colour"));
  CHECK_THROWS_WITH(scale::parse_catalog("catalog:\n  dir: x\n", "c.yaml"), Catch::Contains("lists no table"));
  CHECK_THROWS_WITH(scale::parse_catalog("catalog:\n  presets: [silk]\n  fit: {k_maxx: 3}\n", "c.yaml"),
                    Catch::Contains("k_maxx"));
  CHECK_THROWS_WITH(scale::parse_catalog("catalog:\n  presets: [silk, silk]\n", "c.yaml"),
                    Catch::Contains("names two tables"));
}
