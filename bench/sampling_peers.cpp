// `bsdfmix bench sampling` (bench/sampling_peers.hpp): the samplers' weights with the RGL
// file's f (or the table's), their statistics, the study over random view elevations,
// constant light and scenes, and its CSV.
#include "bench/sampling_peers.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <sstream>
#include <thread>

#include "converge/quadrature.hpp"
#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "core/format.hpp"
#include "core/progress.hpp"
#include "fit/scheduler.hpp"
#include "io/mixture_file.hpp"
#include "io/table.hpp"
#include "scene/light_mixture.hpp"
#include "scene/scene.hpp"
#include "sweep/map_choice.hpp"
#include "tables/rgl_brdf.hpp"

namespace bsdfmix::bench {

namespace {

constexpr std::uint32_t kRglStream = 0x72676c30u;     // "rgl0"
constexpr std::uint32_t kMisRglStream = 0x72676c6du;  // "rglm"
constexpr std::uint32_t kViewStream = 0x76696577u;    // "view"

// The convergence study's estimator whose draw (and density) a peer takes; the RGL peers have none.
Estimator estimator_of(Peer p) {
  switch (p) {
    case Peer::IsMixture: return Estimator::IsTab;
    case Peer::MisMixture: return Estimator::MisTab;
    case Peer::CdfTable: return Estimator::CdfTab;
    case Peer::Light: return Estimator::Light;
    case Peer::MisLightCdf: return Estimator::MisLightCdf;
    case Peer::MisLightGmm: return Estimator::MisLightGmm;
    case Peer::Product: return Estimator::Product;
    case Peer::MisProduct: return Estimator::MisProduct;
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

double cos_factor(Domain d, double theta) { return d == Domain::Hemisphere ? std::cos(theta) : 1.0; }

// L f cos at (theta, phi) (world phi), f the file's luminance or the table.
double integrand(const RglBrdf* brdf, const Problem& p, double theta, double phi) {
  const double f = brdf ? brdf->eval(direction(p.theta_o, 0.0), direction(theta, phi)).y : p.table.f_at(theta, phi);
  if (f == 0) return 0;
  return f * cos_factor(p.table.domain, theta) * p.light.radiance(theta, phi);
}

// The direction a one-sample MIS estimator of the convergence study draws from u: the
// technique picked by u[0] (its remainder the technique's u[0]), as estimate_cpu picks it;
// its density is estimator_pdf's.
bool draw_mis(const Problem& p, Estimator e, const double u[4], double& theta, double& phi) {
  const MisOptions& m = p.mis;
  double c[3] = {0, 0, 0};
  Estimator tech[3] = {Estimator::Light, Estimator::CdfTab, Estimator::UsTab};
  int n = 3;
  if (e == Estimator::MisLightCdf) {
    c[0] = m.light_fraction;
    c[1] = 1 - m.light_fraction;
    n = 2;
  } else if (e == Estimator::MisLightGmm) {
    c[0] = m.light_fraction;
    c[1] = (1 - m.light_fraction) * (1 - m.uniform_fraction);
    c[2] = (1 - m.light_fraction) * m.uniform_fraction;
    tech[1] = Estimator::IsTab;
  } else {  // MisProduct: product, light, uniform
    c[0] = m.product_fraction;
    c[1] = m.product_light;
    c[2] = 1 - m.product_fraction - m.product_light;
    tech[0] = Estimator::Product;
    tech[1] = Estimator::Light;
  }
  int k = 0;
  double lo = 0;
  while (k + 1 < n && u[0] >= lo + c[k]) lo += c[k++];
  const double v[4] = {std::clamp((u[0] - lo) / c[k], 0.0, 1.0 - 1e-17), u[1], u[2], u[3]};
  return draw_cpu(p, tech[k], v, theta, phi);
}

}  // namespace

const char* peer_name(Peer p) {
  static const char* names[kPeers] = {"is_mixture",    "mis_mixture",   "rgl",           "cdf_table",
                                      "uniform",       "light",         "mis_light_rgl", "mis_light_cdf",
                                      "mis_light_gmm", "product",       "mis_product"};
  return names[int(p)];
}

bool peer_needs_rgl(Peer p) { return p == Peer::Rgl || p == Peer::MisLightRgl; }

bool peer_needs_scene(Peer p) { return int(p) >= int(Peer::Light); }

bool peer_studied(Peer p, bool rgl, bool scene) {
  return (rgl || !peer_needs_rgl(p)) && (scene || !peer_needs_scene(p));
}

void WeightStats::add(double w) {
  ++n;
  const double d = w - mean;
  mean += d / double(n);
  m2 += d * (w - mean);
  max = std::max(max, w);
}

std::vector<double> rgl_integrals(const RglBrdf& brdf, double theta_o, const std::vector<const Lighting*>& lights,
                                  int n) {
  // nodes at most a third of the lightings' finest feature apart in phi (pi / n)
  for (const Lighting* l : lights)
    if (!l->is_constant()) n = std::max(n, int(std::ceil(3 * mix::kPi / l->finest_feature())));
  const std::array<double, 3> wo = direction(theta_o, 0.0);
  const double ds = 1.0 / n, dphi = 2 * mix::kPi / (2 * n);
  std::vector<double> sum(lights.size(), 0.0);
  std::vector<double> row(lights.size());
  for (int i = 0; i < n; ++i) {
    const double theta = std::asin(std::sqrt((i + 0.5) * ds));
    std::fill(row.begin(), row.end(), 0.0);
    for (int j = 0; j < 2 * n; ++j) {
      const double phi = -mix::kPi + (j + 0.5) * dphi;
      const double f = brdf.eval(wo, direction(theta, phi)).y;
      if (f == 0) continue;
      for (std::size_t l = 0; l < lights.size(); ++l)
        row[l] += f * (lights[l]->is_constant() ? lights[l]->constant : lights[l]->radiance(theta, phi));
    }
    for (std::size_t l = 0; l < lights.size(); ++l) sum[l] += row[l];
  }
  for (double& s : sum) s *= 0.5 * ds * dphi;  // cos(theta) d(omega) = d(sin^2 theta) / 2 d(phi)
  return sum;
}

double rgl_integral(const RglBrdf& brdf, double theta_o, int n) {
  const Lighting constant = default_lighting(Domain::Hemisphere, 1.0);
  return rgl_integrals(brdf, theta_o, {&constant}, n)[0];
}

double peer_weight(const RglBrdf* brdf, const Problem& p, Peer peer, std::uint64_t seed, std::uint32_t run,
                   std::uint64_t index) {
  const std::array<double, 3> wo = direction(p.theta_o, 0.0);
  const double lf = p.mis.light_fraction;
  double u[4];
  if (peer_needs_rgl(peer) && !brdf) return 0;
  if (peer == Peer::Rgl) {
    run_uniforms(seed, kRglStream, run, index, u);
    const RglBrdf::Sample s = brdf->sample(wo, u[0], u[1]);
    if (!s.valid || !(s.pdf > 0)) return 0;
    const double theta = std::acos(std::clamp(s.omega_i[2], -1.0, 1.0));
    const double phi = std::atan2(s.omega_i[1], s.omega_i[0]);
    const double f = brdf->eval(wo, s.omega_i).y;
    return f == 0 ? 0 : f * s.omega_i[2] * p.light.radiance(theta, phi) / s.pdf;
  }
  if (peer == Peer::MisLightRgl) {
    // light sampling with share lf, the file's warps with the rest; balance heuristic
    run_uniforms(seed, kMisRglStream, run, index, u);
    double theta, phi;
    std::array<double, 3> wi;
    if (u[0] < lf) {
      const double v[4] = {std::clamp(u[0] / lf, 0.0, 1.0 - 1e-17), u[1], u[2], u[3]};
      if (!draw_cpu(p, Estimator::Light, v, theta, phi)) return 0;
      wi = direction(theta, phi);
    } else {
      const RglBrdf::Sample s = brdf->sample(wo, u[1], u[2]);
      if (!s.valid) return 0;
      wi = s.omega_i;
      theta = std::acos(std::clamp(wi[2], -1.0, 1.0));
      phi = std::atan2(wi[1], wi[0]);
    }
    const double pdf = lf * estimator_pdf(p, Estimator::Light, theta, phi) + (1 - lf) * brdf->pdf(wo, wi);
    if (!(pdf > 0)) return 0;
    const double f = brdf->eval(wo, wi).y;
    return f == 0 ? 0 : f * std::max(wi[2], 0.0) * p.light.radiance(theta, phi) / pdf;
  }
  const Estimator e = estimator_of(peer);
  run_uniforms(seed, estimator_stream(int(e)), run, index, u);
  double theta, phi;
  const bool mis = e == Estimator::MisLightCdf || e == Estimator::MisLightGmm || e == Estimator::MisProduct;
  if (!(mis ? draw_mis(p, e, u, theta, phi) : draw_cpu(p, e, u, theta, phi))) return 0;
  const double pdf = estimator_pdf(p, e, theta, phi);
  if (!(pdf > 0)) return 0;
  return integrand(brdf, p, theta, phi) / pdf;
}

WeightStats peer_stats(const RglBrdf* brdf, const Problem& p, Peer peer, std::uint64_t seed, std::uint32_t run,
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

void bench_sampling(const SamplingPeersOptions& o, const std::string& device, bool quiet) {
  if (o.directions < 1 || o.samples < 2 || o.quadrature < 8 || !(o.theta_max_deg > 0 && o.theta_max_deg < 90) ||
      !(o.light_fraction > 0 && o.light_fraction < 1) ||
      !(o.earned || (o.uniform_fraction > 0 && o.uniform_fraction < 1)))
    throw ConfigError("bench sampling: --directions >= 1, --samples >= 2, --quadrature >= 8, 0 < --theta-max < 90, "
                      "0 < --light-fraction < 1, 0 < --uniform-fraction < 1 or earned");
  if (o.mixture.empty() || o.table.empty() || o.csv.empty())
    throw ConfigError("bench sampling: --mixture, --table and --csv are required");
  prepare_output(o.csv);
  std::unique_ptr<RglBrdf> brdf;
  if (!o.rgl.empty()) brdf = std::make_unique<RglBrdf>(o.rgl);
  const TableReader table(o.table);
  const Domain domain = table.meta().domain;
  MixtureFile file = read_mixture_file(o.mixture);
  const mix::MixtureSet set = to_mixture_set(file);
  if (set.domain != domain)
    throw InputError(o.mixture + ": domain " + domain_name(set.domain) + " differs from the table's (" + o.table +
                     ": " + domain_name(domain) + ")");
  if (brdf && domain != Domain::Hemisphere)
    throw InputError(o.mixture + ": bench sampling with --rgl needs a hemisphere mixture and table");
  file.storage = MixtureStorage{true, true};  // as `bsdfmix pack` stores it by default

  // Constant light first, then each scene, with its lighting mixture (the product's).
  std::vector<Lighting> lights{default_lighting(domain, 1.0)};
  lights[0].name = "constant";
  for (const std::string& f : o.scenes) {
    YAML::Node node;
    try {
      node = YAML::LoadFile(f);
    } catch (const YAML::BadFile&) {
      throw ConfigError(f + ": cannot read scene file");
    } catch (const YAML::Exception& e) {
      throw ConfigError(f + ": " + e.what());
    }
    lights.push_back(parse_scene(node, f, "", domain));
    lights.back().domain = domain;
  }
  std::vector<LightMixture> light_mix(lights.size());
  for (std::size_t l = 1; l < lights.size(); ++l) {
    FitSettings fit;
    fit.k_max = 16;  // as `converge` without a fit section
    fit.map = map_setting(set.map);  // the product needs one plane
    const std::string cache = !o.light_cache.empty() ? o.light_cache
                                                     : (std::filesystem::path(o.csv).parent_path() / "light_mixtures").string();
    light_mix[l] = lighting_mixture(lights[l], table.meta(), fit, cache, device, o.light_engine);
    if (!quiet)
      log_line("bench sampling: lighting '" + lights[l].name + "': K " + std::to_string(light_mix[l].k) + " (" +
               light_mix[l].path + ")");
  }

  std::uint64_t bytes[kPeers];
  for (int k = 0; k < kPeers; ++k) {
    switch (Peer(k)) {
      case Peer::Rgl:
      case Peer::MisLightRgl: bytes[k] = brdf ? std::uint64_t(std::filesystem::file_size(o.rgl)) : 0; break;
      case Peer::CdfTable:
      case Peer::MisLightCdf:
        bytes[k] = std::uint64_t(table.meta().n_slices() * table.meta().cells_per_slice() * sizeof(float));
        break;
      case Peer::Uniform:
      case Peer::Light: bytes[k] = 0; break;
      default: bytes[k] = file.payload_bytes();
    }
  }
  const std::vector<double> views = study_directions(o.directions, o.theta_max_deg * mix::kPi / 180, o.seed);
  MisOptions mis;
  mis.uniform_fraction = o.uniform_fraction;
  mis.earned = o.earned;
  mis.light_fraction = o.light_fraction;

  struct Cell {  // one view under one lighting
    double integral = 0;
    WeightStats stats[kPeers];
  };
  const std::size_t nl = lights.size();
  std::vector<Cell> cells(views.size() * nl);
  Progress progress("bench sampling " + material_name(brdf ? o.rgl : o.table), views.size(), "views");
  // one view a job; an error in any (a product with no overlap, say) is rethrown here
  const unsigned threads = std::max(1u, std::min(std::thread::hardware_concurrency(), unsigned(views.size())));
  run_on_workers(views.size(), threads, [&](std::size_t, std::size_t d) {
    std::vector<double> integral(nl);
    if (brdf) {
      std::vector<const Lighting*> lp;
      for (const Lighting& l : lights) lp.push_back(&l);
      integral = rgl_integrals(*brdf, views[d], lp, o.quadrature);
    }
    for (std::size_t l = 0; l < nl; ++l) {
      Problem p = make_problem(table, set, views[d], 0.0, lights[l], mis, l ? &light_mix[l].mixture : nullptr);
      if (l) {  // mis_product's fractions chosen per view and lighting, as `converge` does by default
        const ProductTuning tu = tune_product_fractions(p);
        p.mis.product_fraction = tu.product_fraction;
        p.mis.product_light = tu.product_light;
      }
      Cell& c = cells[d * nl + l];
      c.integral = brdf ? integral[l] : table_integral(p);
      for (int k = 0; k < kPeers; ++k)
        if (peer_studied(Peer(k), bool(brdf), l > 0))
          c.stats[k] = peer_stats(brdf.get(), p, Peer(k), o.seed, std::uint32_t(d), o.samples);
    }
    progress.advance();
  });
  progress.finish();

  const std::string material = material_name(brdf ? o.rgl : o.table);
  std::ostringstream csv;
  csv << "material,lighting,theta_o_deg,sampler,samples,integral,mean_over_integral,relvar,max_weight_over_integral,"
         "bytes\n";
  for (std::size_t l = 0; l < nl; ++l)
    for (std::size_t d = 0; d < views.size(); ++d)
      for (int k = 0; k < kPeers; ++k) {
        if (!peer_studied(Peer(k), bool(brdf), l > 0)) continue;
        const Cell& c = cells[d * nl + l];
        const WeightStats& s = c.stats[k];
        const double i = c.integral;
        csv << material << ',' << lights[l].name << ',' << format_number(views[d] * 180 / mix::kPi, "%.4f") << ','
            << peer_name(Peer(k)) << ',' << s.n << ',' << format_number(i, "%.6g") << ','
            << format_number(s.mean / i, "%.6g") << ',' << format_number(s.relvar(i), "%.6g") << ','
            << format_number(s.max / i, "%.6g") << ',' << bytes[k] << '\n';
      }
  write_text_atomic(o.csv, csv.str());
  if (quiet) return;
  for (std::size_t l = 0; l < nl; ++l) {
    // against the file's own sampler (mis_light_rgl under a scene); without a file,
    // against the table CDF under a scene and uniform under constant light
    const Peer ref = brdf ? (l ? Peer::MisLightRgl : Peer::Rgl) : (l ? Peer::CdfTable : Peer::Uniform);
    std::printf("%s, %s: %d view elevations in [0, %g] degrees, %llu samples each; variance per sample against %s\n",
                material.c_str(), lights[l].name.c_str(), o.directions, o.theta_max_deg,
                static_cast<unsigned long long>(o.samples), peer_name(ref));
    std::printf("%-14s %12s %12s %12s\n", "sampler", "median", "max", "bytes");
    for (int k = 0; k < kPeers; ++k) {
      if (!peer_studied(Peer(k), bool(brdf), l > 0)) continue;
      std::vector<double> ratio;
      for (std::size_t d = 0; d < views.size(); ++d) {
        const Cell& c = cells[d * nl + l];
        ratio.push_back(c.stats[k].relvar(c.integral) / c.stats[int(ref)].relvar(c.integral));
      }
      std::printf("%-14s %12.4g %12.4g %12llu\n", peer_name(Peer(k)), median(ratio),
                  *std::max_element(ratio.begin(), ratio.end()), static_cast<unsigned long long>(bytes[k]));
    }
  }
}

}  // namespace bsdfmix::bench
