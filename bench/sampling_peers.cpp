// `bsdfmix bench sampling` (bench/sampling_peers.hpp): the samplers' weights with the RGL
// file's f, their statistics, the study over random view elevations and its CSV.
#include "bench/sampling_peers.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>
#include <thread>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "core/format.hpp"
#include "io/mixture_file.hpp"
#include "io/table.hpp"
#include "tables/rgl_brdf.hpp"

namespace bsdfmix::bench {

namespace {

constexpr std::uint32_t kRglStream = 0x72676c30u;   // "rgl0"
constexpr std::uint32_t kViewStream = 0x76696577u;  // "view"

Estimator estimator_of(Peer p) {
  switch (p) {
    case Peer::IsMixture: return Estimator::IsTab;
    case Peer::MisMixture: return Estimator::MisTab;
    case Peer::CdfTable: return Estimator::CdfTab;
    default: return Estimator::UsTab;
  }
}

std::array<double, 3> direction(double theta, double phi) {
  return {std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)};
}

double median(std::vector<double> v) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

std::string material_name(const std::string& path) {
  std::string stem = std::filesystem::path(path).stem().string();
  const std::string rgb = "_rgb";
  if (stem.size() > rgb.size() && stem.compare(stem.size() - rgb.size(), rgb.size(), rgb) == 0)
    stem.resize(stem.size() - rgb.size());
  return stem;
}

}  // namespace

const char* peer_name(Peer p) {
  static const char* names[kPeers] = {"is_mixture", "mis_mixture", "rgl", "cdf_table", "uniform"};
  return names[int(p)];
}

void WeightStats::add(double w) {
  ++n;
  const double d = w - mean;
  mean += d / double(n);
  m2 += d * (w - mean);
  max = std::max(max, w);
}

double rgl_integral(const RglBrdf& brdf, double theta_o, int n) {
  const std::array<double, 3> wo = direction(theta_o, 0.0);
  const double ds = 1.0 / n, dphi = 2 * mix::kPi / (2 * n);
  double sum = 0;
  for (int i = 0; i < n; ++i) {
    const double theta = std::asin(std::sqrt((i + 0.5) * ds));
    double row = 0;
    for (int j = 0; j < 2 * n; ++j) row += brdf.eval(wo, direction(theta, -mix::kPi + (j + 0.5) * dphi)).y;
    sum += row;
  }
  return sum * 0.5 * ds * dphi;  // cos(theta) d(omega) = d(sin^2 theta) / 2 d(phi)
}

double peer_weight(const RglBrdf& brdf, const Problem& p, Peer peer, std::uint64_t seed, std::uint32_t run,
                   std::uint64_t index) {
  const std::array<double, 3> wo = direction(p.theta_o, 0.0);
  double u[4];
  if (peer == Peer::Rgl) {
    run_uniforms(seed, kRglStream, run, index, u);
    const RglBrdf::Sample s = brdf.sample(wo, u[0], u[1]);
    if (!s.valid || !(s.pdf > 0)) return 0;
    return brdf.eval(wo, s.omega_i).y * s.omega_i[2] / s.pdf;
  }
  const Estimator e = estimator_of(peer);
  run_uniforms(seed, estimator_stream(int(e)), run, index, u);
  double theta, phi;
  if (!draw_cpu(p, e, u, theta, phi)) return 0;
  const double pdf = estimator_pdf(p, e, theta, phi);
  if (!(pdf > 0)) return 0;
  return brdf.eval(wo, direction(theta, phi)).y * std::cos(theta) / pdf;
}

WeightStats peer_stats(const RglBrdf& brdf, const Problem& p, Peer peer, std::uint64_t seed, std::uint32_t run,
                       std::uint64_t n) {
  WeightStats s;
  for (std::uint64_t i = 0; i < n; ++i) s.add(peer_weight(brdf, p, peer, seed, run, i));
  return s;
}

std::vector<double> study_directions(int count, double theta_max, std::uint64_t seed) {
  std::vector<double> out;
  for (int i = 0; i < count; ++i) {
    double u[4];
    run_uniforms(seed, kViewStream, 0, std::uint64_t(i), u);
    out.push_back(u[0] * theta_max);
  }
  return out;
}

void bench_sampling(const SamplingPeersOptions& o, bool quiet) {
  if (o.directions < 1 || o.samples < 2 || o.quadrature < 8 || !(o.theta_max_deg > 0 && o.theta_max_deg < 90))
    throw ConfigError("bench sampling: --directions >= 1, --samples >= 2, --quadrature >= 8, 0 < --theta-max < 90");
  prepare_output(o.csv);
  const RglBrdf brdf(o.rgl);
  const TableReader table(o.table);
  MixtureFile file = read_mixture_file(o.mixture);
  const mix::MixtureSet set = to_mixture_set(file);
  if (set.domain != Domain::Hemisphere || table.meta().domain != Domain::Hemisphere)
    throw InputError(o.mixture + ": bench sampling needs a hemisphere mixture and table");
  file.storage = MixtureStorage{true, true};  // as `bsdfmix pack` stores it by default
  const std::uint64_t bytes[kPeers] = {
      file.payload_bytes(), file.payload_bytes(), std::uint64_t(std::filesystem::file_size(o.rgl)),
      std::uint64_t(table.meta().n_slices() * table.meta().cells_per_slice() * sizeof(float)), 0};
  const std::vector<double> views = study_directions(o.directions, o.theta_max_deg * mix::kPi / 180, o.seed);

  struct Row {
    double integral = 0;
    WeightStats stats[kPeers];
  };
  std::vector<Row> rows(views.size());
  std::atomic<std::size_t> next{0};
  auto work = [&] {
    for (std::size_t d; (d = next++) < views.size();) {
      const Problem p = make_problem(table, set, views[d], 0.0, default_lighting(Domain::Hemisphere), o.uniform_fraction);
      rows[d].integral = rgl_integral(brdf, views[d], o.quadrature);
      for (int k = 0; k < kPeers; ++k) rows[d].stats[k] = peer_stats(brdf, p, Peer(k), o.seed, std::uint32_t(d), o.samples);
    }
  };
  std::vector<std::thread> pool;
  const unsigned threads = std::max(1u, std::min(std::thread::hardware_concurrency(), unsigned(views.size())));
  for (unsigned t = 1; t < threads; ++t) pool.emplace_back(work);
  work();
  for (auto& t : pool) t.join();

  const std::string material = material_name(o.rgl);
  std::ostringstream csv;
  csv << "material,theta_o_deg,sampler,samples,integral,mean_over_integral,relvar,max_weight_over_integral,bytes\n";
  for (std::size_t d = 0; d < views.size(); ++d)
    for (int k = 0; k < kPeers; ++k) {
      const WeightStats& s = rows[d].stats[k];
      const double i = rows[d].integral;
      csv << material << ',' << format_number(views[d] * 180 / mix::kPi, "%.4f") << ',' << peer_name(Peer(k)) << ','
          << s.n << ',' << format_number(i, "%.6g") << ',' << format_number(s.mean / i, "%.6g") << ','
          << format_number(s.relvar(i), "%.6g") << ',' << format_number(s.max / i, "%.6g") << ',' << bytes[k] << '\n';
    }
  write_text_atomic(o.csv, csv.str());
  if (quiet) return;
  std::printf("%s: %d view elevations in [0, %g] degrees, %llu samples each; variance per sample against rgl\n",
              material.c_str(), o.directions, o.theta_max_deg, static_cast<unsigned long long>(o.samples));
  std::printf("%-12s %12s %12s %12s\n", "sampler", "median", "max", "bytes");
  for (int k = 0; k < kPeers; ++k) {
    std::vector<double> ratio;
    for (const Row& r : rows) ratio.push_back(r.stats[k].relvar(r.integral) / r.stats[int(Peer::Rgl)].relvar(r.integral));
    std::printf("%-12s %12.4g %12.4g %12llu\n", peer_name(Peer(k)), median(ratio),
                *std::max_element(ratio.begin(), ratio.end()), static_cast<unsigned long long>(bytes[k]));
  }
}

}  // namespace bsdfmix::bench
