// `bsdfmix bench sampling` (bench/sampling_peers.*): each sampler's estimate of the
// integral of L f cos over the hemisphere, f the RGL file's (or the table's), agrees with
// the quadrature under constant light and under the sky, and the variance per sample it
// reports is the variance of the estimates.
#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>
#include <string>

#include <yaml-cpp/yaml.h>

#include "bench/sampling_peers.hpp"
#include "converge/quadrature.hpp"
#include "core/progress.hpp"
#include "io/table.hpp"
#include "scene/scene.hpp"
#include "tables/rgl_brdf.hpp"
#include "tables/rgl_import.hpp"

using namespace bsdfmix;
using namespace bsdfmix::bench;
namespace fs = std::filesystem;

namespace {

std::string paper_white() { return std::string(BSDFMIX_SOURCE_DIR) + "/data/rgl/paper_white_rgb.bsdf"; }

// A coarse table of paper_white, imported once.
std::string paper_table() {
  const fs::path dir = fs::temp_directory_path() / "bsdfmix_sampling_peers_test";
  fs::create_directories(dir);
  const std::string path = (dir / "paper.h5").string();
  if (!fs::exists(path)) {
    Progress::set_enabled(false);
    RglImportOptions o;
    o.file = paper_white();
    o.n_theta_o = 9;
    o.n_theta_i = 30;
    o.n_phi_i = 60;
    import_rgl_table(o, path);
  }
  return path;
}

// Per table slice a broad Gaussian and one at the mirror direction: a density > 0 over
// the whole hemisphere, so every mixture sampler is unbiased.
mix::MixtureSet broad_mixture(const TableMeta& meta) {
  mix::MixtureSet set;
  set.domain = mix::Domain::Hemisphere;
  set.azimuthal = true;
  set.grid_theta_o = meta.theta_o;
  set.grid_phi_o = meta.phi_o;
  for (double t : meta.theta_o) {
    mix::SliceMixture s;
    s.theta_o = t;
    s.scale = 1;
    mix::Gaussian broad, mirror;
    broad.weight = 0.7;
    broad.mu_t = 0.7;
    broad.s_tt = 0.5;
    broad.s_pp = 4.0;
    mirror.weight = 0.3;
    mirror.mu_t = t;
    mirror.mu_p = 3.0;
    mirror.s_tt = 0.05;
    mirror.s_pp = 0.2;
    s.components = {broad, mirror};
    set.slices.push_back(s);
  }
  set.prepare();
  return set;
}

Lighting sky() {
  const std::string path = std::string(BSDFMIX_SOURCE_DIR) + "/configs/scenes/sky.yaml";
  return parse_scene(YAML::LoadFile(path), path, "", Domain::Hemisphere);
}

// A stand-in for the sky's lighting mixture (the product's other factor): a broad
// Gaussian and one at the sun. Any mixture will do: the product's estimators divide by
// the density they draw from.
mix::SliceMixture sky_mixture(const Lighting& l) {
  const Vec3 sun = l.lobes.at(0).direction;
  mix::SliceMixture m;
  m.scale = 1;
  mix::Gaussian broad, disc;
  broad.weight = 0.6;
  broad.mu_t = 0.8;
  broad.s_tt = 0.4;
  broad.s_pp = 4.0;
  disc.weight = 0.4;
  disc.mu_t = std::acos(sun[2]);
  disc.mu_p = std::atan2(sun[1], sun[0]);
  disc.s_tt = 0.004;
  disc.s_pp = 0.02;
  m.components = {broad, disc};
  m.prepare();
  return m;
}

// n runs of `per` samples of a peer and one long run of n * per: the mean of the run
// means and the long run's mean against the integral, within 4 standard errors (and
// `quad` of it for the quadrature), and the spread of the run means against the
// variance per sample that the long run reports.
void check_unbiased(const RglBrdf* brdf, const Problem& p, Peer peer, double integral, double quad) {
  const int runs = 8;
  const std::uint64_t n = 4096;
  double sum = 0, sum2 = 0;
  for (int r = 0; r < runs; ++r) {
    const double m = peer_stats(brdf, p, peer, 7, std::uint32_t(r), n).mean;
    sum += m;
    sum2 += m * m;
  }
  const WeightStats all = peer_stats(brdf, p, peer, 8, 0, runs * n);
  const double mean = sum / runs, spread = (sum2 - runs * mean * mean) / (runs - 1);
  const double se = std::sqrt(all.variance() / double(runs * n));
  INFO(peer_name(peer) << " under " << p.light.name << " at theta_o " << p.theta_o << ": mean " << mean
                       << ", long run " << all.mean << ", integral " << integral << ", relvar "
                       << all.relvar(integral));
  CHECK(std::abs(mean - integral) < 4 * se + quad * integral);
  CHECK(std::abs(all.mean - integral) < 4 * se + quad * integral);
  CHECK(all.max >= all.mean);
  if (all.relvar(integral) < 1e-9) return;  // exact (the table CDF with f the table): no spread to compare
  // the run means' variance is the variance per sample over n: 7 degrees of freedom
  // put it within a factor 4 either way (chi-square, far tails)
  CHECK(spread < 4 * all.variance() / double(n));
  CHECK(spread > all.variance() / double(n) / 8);
}

}  // namespace

TEST_CASE("the weights' statistics on a tiny case") {
  WeightStats s;
  for (double w : {1.0, 2.0, 3.0, 4.0}) s.add(w);
  CHECK(s.n == 4);
  CHECK(s.mean == Approx(2.5));
  CHECK(s.variance() == Approx(5.0 / 3.0));  // sum of (w - 2.5)^2 = 5, over n - 1
  CHECK(s.relvar(2.0) == Approx(5.0 / 12.0));
  CHECK(s.max == 4.0);
}

TEST_CASE("every sampler's estimate agrees with the quadrature of the file's f cos") {
  const RglBrdf brdf(paper_white());
  const TableReader table(paper_table());
  const mix::MixtureSet set = broad_mixture(table.meta());
  for (double theta_o : {0.3, 1.1}) {
    const Problem p = make_problem(table, set, theta_o, 0.0, default_lighting(Domain::Hemisphere), 0.1);
    const double integral = rgl_integral(brdf, theta_o, 256);
    CHECK(rgl_integral(brdf, theta_o, 512) == Approx(integral).epsilon(2e-3));
    for (int k = 0; k < kPeers; ++k)
      if (peer_studied(Peer(k), true, false)) check_unbiased(&brdf, p, Peer(k), integral, 2e-3);
  }
}

TEST_CASE("under the sky, is_rgl, mis_light_rgl and the light and product samplers agree with the quadrature") {
  const RglBrdf brdf(paper_white());
  const TableReader table(paper_table());
  const mix::MixtureSet set = broad_mixture(table.meta());
  const Lighting l = sky();
  const mix::SliceMixture lm = sky_mixture(l);
  const Lighting constant = default_lighting(Domain::Hemisphere, 1.0);
  MisOptions mis;
  for (double theta_o : {0.3, 1.1}) {
    const Problem p = make_problem(table, set, theta_o, 0.0, l, mis, &lm);
    // one pass gives every lighting's integral: constant light's is rgl_integral's
    const std::vector<double> both = rgl_integrals(brdf, theta_o, {&constant, &l}, 256);
    CHECK(both[0] == Approx(rgl_integral(brdf, theta_o, 256)));
    const double integral = both[1];
    CHECK(rgl_integrals(brdf, theta_o, {&l}, 512)[0] == Approx(integral).epsilon(2e-3));
    CHECK(integral > both[0] * l.constant);  // the sun and the sky add to the constant term
    for (int k = 0; k < kPeers; ++k) {
      REQUIRE(peer_studied(Peer(k), true, true));
      check_unbiased(&brdf, p, Peer(k), integral, 2e-3);
    }
  }
}

TEST_CASE("without an RGL file f is the table: its estimators agree with the table's integral") {
  const TableReader table(paper_table());
  const mix::MixtureSet set = broad_mixture(table.meta());
  const Lighting l = sky();
  const mix::SliceMixture lm = sky_mixture(l);
  MisOptions mis;
  CHECK(!peer_studied(Peer::Rgl, false, true));
  CHECK(!peer_studied(Peer::MisLightRgl, false, true));
  CHECK(!peer_studied(Peer::Light, false, false));
  CHECK(peer_studied(Peer::MisMixture, false, false));
  for (const Lighting& light : {default_lighting(Domain::Hemisphere, 1.0), l}) {
    const Problem p = make_problem(table, set, 0.7, 0.0, light, mis, light.is_constant() ? nullptr : &lm);
    const double integral = table_integral(p);
    for (int k = 0; k < kPeers; ++k)
      if (peer_studied(Peer(k), false, !light.is_constant())) check_unbiased(nullptr, p, Peer(k), integral, light.is_constant() ? 1e-6 : 1e-4);
  }
}

TEST_CASE("the view elevations are fixed by the seed and lie in range") {
  const auto a = study_directions(20, 1.4, 1), b = study_directions(20, 1.4, 1), c = study_directions(20, 1.4, 2);
  CHECK(a == b);
  CHECK(a != c);
  for (double t : a) CHECK((t >= 0 && t < 1.4));
}
