// The uniform share each slice earns (sweep/earned_share.hpp; docs/sampling.md, "The
// earned share"): 0 where the mixture is exact, above 0 where it misses a lobe, always the
// smallest ladder share whose largest weight is no larger than 0.1's; the file's
// `defensive` round trip (absent: 0.1; out of range refused); MixtureSet::defensive blends
// the slices' shares.
// labels: fit
#include <catch2/catch.hpp>

#include <hdf5.h>

#include <cmath>
#include <filesystem>
#include <tuple>

#include "core/error.hpp"
#include "io/mixture_file.hpp"
#include "io/table.hpp"
#include "sweep/earned_share.hpp"

using namespace bsdfmix;
namespace fs = std::filesystem;

namespace {

// A hemisphere slice of 45 x 90 cells on the disk map (the fit's default plane).
WeightedSlice hemisphere_slice() {
  const TableMeta meta = make_grid(Domain::Hemisphere, 1, 1, 45, 90, true);
  WeightedSlice s;
  s.theta = meta.theta_i;
  s.phi = meta.phi_i;
  s.map = mix::Map::Disk;
  return s;
}

// A mixture on the disk with one Gaussian of width `sigma` at each (theta, phi) of `lobes`.
mix::SliceMixture disk_mixture(const std::vector<std::pair<double, double>>& lobes, double sigma) {
  std::vector<double> w, mean, cov;
  for (const auto& [theta, phi] : lobes) {
    double x, y;
    mix::to_map(mix::Map::Disk, theta, phi, x, y);
    w.push_back(1.0);
    mean.insert(mean.end(), {x, y});
    cov.insert(cov.end(), {sigma * sigma, 0.0, sigma * sigma});
  }
  mix::SliceMixture m = mix::make_slice_mixture(w, mean, cov);
  m.map = mix::Map::Disk;
  return m;
}

// The slice's weights: `integral` times the masses of `truth` in its cells.
WeightedSlice slice_of(const mix::SliceMixture& truth, double integral) {
  WeightedSlice s = hemisphere_slice();
  s.w = cell_masses(s, truth);
  for (double& x : s.w) x *= integral;
  return s;
}

// The share is the smallest ladder value whose largest weight is at most kWeightCap or no
// larger than 0.1's.
void check_smallest(const WeightedSlice& s, const mix::SliceMixture& m, const EarnedShare& e) {
  const std::vector<double> masses = cell_masses(s, m), uniform = uniform_masses(s, Domain::Hemisphere);
  const double bound = std::max(max_weight(s, masses, uniform, 0.1), kWeightCap);
  CHECK(e.max_weight == max_weight(s, masses, uniform, e.share));
  CHECK(e.max_weight <= bound);
  for (const double a : kShareLadder)
    if (a < e.share) CHECK(max_weight(s, masses, uniform, a) > bound);
}

fs::path temp_dir() {
  const fs::path d = fs::temp_directory_path() / "bsdfmix_earned_share_test";
  fs::create_directories(d);
  return d;
}

MixtureFile two_slices() {
  MixtureFile m;
  m.domain = Domain::Hemisphere;
  m.azimuthal = true;
  m.table_theta_o = {0.2, 0.6};
  m.table_phi_o = {0.0};
  for (const double to : {0.2, 0.6}) m.add_slice(to, 0.0, 1.0, 0.0, 0.01, {1.0}, {0.5, 0.0}, {0.04, 0.0, 0.04});
  return m;
}

}  // namespace

TEST_CASE("an exact mixture earns share 0; one missing a lobe earns more", "[fit]") {
  const mix::SliceMixture truth = disk_mixture({{0.5, 0.3}, {1.1, -2.0}}, 0.12);
  const WeightedSlice s = slice_of(truth, 3.0);
  const EarnedShare exact = earned_share(s, truth, Domain::Hemisphere);
  CHECK(exact.share == 0.0);
  CHECK(exact.max_weight == Approx(1.0).epsilon(0.02));  // w_i / m_i = I wherever the mixture is exact
  check_smallest(s, truth, exact);

  const mix::SliceMixture one_lobe = disk_mixture({{0.5, 0.3}}, 0.12);  // misses the lobe at (1.1, -2.0)
  const EarnedShare missed = earned_share(s, one_lobe, Domain::Hemisphere);
  CHECK(missed.share > 0.0);
  CHECK(missed.max_weight > 1.0);
  check_smallest(s, one_lobe, missed);

  // A mixture a little too narrow (sigma 0.118 for f's 0.12): its tails fall faster than
  // f's, and leave the far cells unsampled; a share between the ends suffices.
  const mix::SliceMixture narrow = disk_mixture({{0.5, 0.3}, {1.1, -2.0}}, 0.118);
  const EarnedShare tails = earned_share(s, narrow, Domain::Hemisphere);
  INFO("narrow mixture: share " << tails.share << ", largest weight " << tails.max_weight);
  CHECK(tails.share > 0.0);
  CHECK(tails.share < 0.1);
  check_smallest(s, narrow, tails);
}

TEST_CASE("a zero slice earns 0; a cell the mixture never reaches makes W infinite", "[fit]") {
  WeightedSlice s = hemisphere_slice();
  s.w.assign(s.theta.size() * s.phi.size(), 0.0);
  const mix::SliceMixture m = disk_mixture({{0.5, 0.3}}, 0.05);
  CHECK(earned_share(s, m, Domain::Hemisphere).share == 0.0);
  const std::vector<double> masses(s.w.size(), 0.0), uniform = uniform_masses(s, Domain::Hemisphere);
  s.w[7] = 1.0;
  CHECK(std::isinf(max_weight(s, masses, uniform, 0.0)));
  CHECK(std::isfinite(max_weight(s, masses, uniform, 0.002)));
  double total = 0;
  for (double u : uniform) total += u;
  CHECK(total == Approx(1.0).epsilon(1e-3));  // the uniform density's masses cover the hemisphere
}

TEST_CASE("the file's defensive round trips; absent reads 0.1; out of range is refused", "[fit]") {
  MixtureFile m = two_slices();
  CHECK(m.defensive == std::vector<double>{0.1, 0.1});  // add_slice's default
  m.defensive = {0.0, 0.02};
  const std::string path = (temp_dir() / "shares.h5").string();
  write_mixture_file(path, m);
  CHECK(read_mixture_file(path).defensive == std::vector<double>{0.0, 0.02});
  const mix::MixtureSet set = to_mixture_set(read_mixture_file(path));
  CHECK(set.slices[0].defensive == 0.0);
  CHECK(set.slices[1].defensive == 0.02);
  CHECK(set.defensive(0.2, 0.0) == 0.0);
  CHECK(set.defensive(0.4, 0.0) == Approx(0.01));  // halfway: the blend weights
  CHECK(set.defensive(0.6, 1.0) == Approx(0.02));

  MixtureFile copy = m.header_only();  // add_slice_from keeps the share
  copy.add_slice_from(m, 1);
  CHECK(copy.defensive == std::vector<double>{0.02});

  {  // a file written before the dataset: 0.1 for every slice
    const hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    REQUIRE(f >= 0);
    H5Ldelete(f, "/mixture/defensive", H5P_DEFAULT);
    H5Fclose(f);
  }
  CHECK(read_mixture_file(path).defensive == std::vector<double>{0.1, 0.1});
  CHECK(to_mixture_set(read_mixture_file(path)).defensive(0.4, 0.0) == Approx(0.1));

  m.defensive = {0.0, 1.0};
  write_mixture_file(path, m);
  CHECK_THROWS_WITH(read_mixture_file(path), Catch::Contains("slice 1: defensive is not a share in [0, 1)"));
}

TEST_CASE("Displace blends the shares with the same weights", "[fit]") {
  MixtureFile m = two_slices();
  m.defensive = {0.05, 0.0};
  m.interpolation = mix::Interpolation::Displace;
  const mix::MixtureSet set = to_mixture_set(m);
  CHECK(set.defensive(0.3, 0.0) == Approx(0.0375));
  CHECK(set.at(0.3, 0.0).defensive == Approx(0.0375));
  CHECK(set.serving(0.3, 0.0).defensive(0.3, 0.0) == Approx(0.0375));
}

// Two lobes of width `sigma` over a broad floor (sigma 1) of weight `floor_weight`.
mix::SliceMixture lobes_on_floor(double sigma, double floor_weight) {
  std::vector<double> w, mean, cov;
  const std::vector<std::tuple<double, double, double, double>> parts = {
      {0.5, 0.3, sigma, 1.0}, {1.1, -2.0, sigma, 1.0}, {0.0, 0.0, 1.0, floor_weight}};
  for (const auto& [theta, phi, width, weight] : parts) {
    double x, y;
    mix::to_map(mix::Map::Disk, theta, phi, x, y);
    w.push_back(weight);
    mean.insert(mean.end(), {x, y});
    cov.insert(cov.end(), {width * width, 0.0, width * width});
  }
  mix::SliceMixture m = mix::make_slice_mixture(w, mean, cov);
  m.map = mix::Map::Disk;
  return m;
}

TEST_CASE("a largest weight under kWeightCap needs no share; one above it does", "[fit]") {
  const WeightedSlice s = slice_of(lobes_on_floor(0.12, 0.2), 3.0);
  const std::vector<double> uniform = uniform_masses(s, Domain::Hemisphere);
  // Lobes a little narrow, half the floor: 0.1 would bound the weight lower, but it is
  // under the cap without a share.
  const mix::SliceMixture near = lobes_on_floor(0.114, 0.1);
  const std::vector<double> near_masses = cell_masses(s, near);
  const double w0 = max_weight(s, near_masses, uniform, 0.0);
  CHECK(w0 > max_weight(s, near_masses, uniform, 0.1));
  CHECK(w0 < kWeightCap);
  const EarnedShare none = earned_share(s, near, Domain::Hemisphere);
  CHECK(none.share == 0.0);
  check_smallest(s, near, none);
  // Lobes far too narrow: above the cap, the share bounds the weight.
  const mix::SliceMixture narrow = lobes_on_floor(0.1, 0.1);
  CHECK(max_weight(s, cell_masses(s, narrow), uniform, 0.0) > kWeightCap);
  const EarnedShare some = earned_share(s, narrow, Domain::Hemisphere);
  CHECK(some.share > 0.0);
  CHECK(some.max_weight <= kWeightCap);
  check_smallest(s, narrow, some);
}
