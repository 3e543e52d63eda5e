// The header's MixtureSet (include/bsdfmix/mixture.hpp): prepare() refuses a grid that
// contradicts the slices or the symmetry; eval_f and eval_rgb are 0 at and past the
// hemisphere's horizon while pdf_omega stays the sampling density; the sample stream of
// `bsdfmix sample` is the header's kSampleStream.
// labels: sample
#include <catch2/catch.hpp>

#include <bsdfmix/mixture.hpp>

#include <cmath>
#include <stdexcept>
#include <string>

#include "sampling/sampling.hpp"

using namespace bsdfmix;

namespace {

mix::SliceMixture slice(double theta_o, double phi_o) {
  mix::SliceMixture s = mix::make_slice_mixture({0.6, 0.4}, {0.5, 0.2, 1.2, -1.0}, {0.05, 0.0, 0.3, 0.2, 0.05, 0.4});
  s.theta_o = theta_o;
  s.phi_o = phi_o;
  s.scale = 1.3;
  return s;
}

// A hemisphere set on the disk map: two theta_o rows, with or without symmetry.
mix::MixtureSet disk_set(bool azimuthal) {
  mix::MixtureSet set;
  set.domain = mix::Domain::Hemisphere;
  set.map = mix::Map::Disk;
  set.azimuthal = azimuthal;
  set.grid_theta_o = {0.3, 0.9};
  set.grid_phi_o = azimuthal ? std::vector<double>{0.0} : std::vector<double>{-kPi / 2, kPi / 2};
  for (const double t : set.grid_theta_o)
    for (const double p : set.grid_phi_o) set.slices.push_back(slice(t, p));
  return set;
}

// prepare()'s message, "" when it accepts the set.
std::string refusal(mix::MixtureSet set) {
  try {
    set.prepare();
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST_CASE("prepare refuses a grid that contradicts the slices or the symmetry", "[sample]") {
  CHECK(refusal(disk_set(true)).empty());
  CHECK(refusal(disk_set(false)).empty());
  mix::MixtureSet one_column = disk_set(true);
  one_column.azimuthal = false;  // a symmetric file read without its symmetry
  CHECK(refusal(one_column).find("azimuthal = false needs 2 or more grid_phi_o columns") != std::string::npos);
  mix::MixtureSet two_columns = disk_set(false);
  two_columns.azimuthal = true;
  CHECK(refusal(two_columns).find("azimuthal = true needs one grid_phi_o column") != std::string::npos);
  mix::MixtureSet off_grid = disk_set(true);
  off_grid.slices[1].theta_o = 0.7;
  CHECK(refusal(off_grid).find("slice 1 (theta_o 0.700000") != std::string::npos);
  mix::MixtureSet twice = disk_set(true);
  twice.slices[1].theta_o = 0.3;
  CHECK(refusal(twice).find("slices 0 and 1 lie on one grid point") != std::string::npos);
  mix::MixtureSet uneven = disk_set(true);
  uneven.grid_theta_o = {0.3, 0.9, 1.0};
  CHECK(refusal(uneven).find("grid_theta_o is not a finite, increasing, uniformly spaced axis") != std::string::npos);
  mix::MixtureSet empty = disk_set(true);
  empty.grid_phi_o.clear();
  CHECK(refusal(empty).find("grid_phi_o is empty") != std::string::npos);
  // serving() of a set without symmetry holds one column by design.
  mix::MixtureSet nosym = disk_set(false);
  nosym.prepare();
  const mix::MixtureSet one = nosym.serving(0.5, 0.4);
  CHECK(one.eval_f(0.5, 0.4, 0.6, 1.0) == Approx(nosym.eval_f(0.5, 0.4, 0.6, 1.0)).epsilon(1e-12));
}

TEST_CASE("eval_f and eval_rgb are 0 at and past the hemisphere's horizon; pdf_omega is the sampling density",
          "[sample]") {
  for (const mix::Map map : {mix::Map::Disk, mix::Map::ThetaPhi}) {
    mix::MixtureSet set = disk_set(true);
    set.map = map;
    set.slices[0].components[1].mu_t = map == mix::Map::Disk ? 1.3 : 1.5;  // a lobe at the horizon
    set.prepare();
    INFO("map " << int(map));
    double rgb[3];
    for (const double t : {kPi / 2, kPi / 2 + 1e-9, 1.7, 3.0}) {
      CHECK(set.eval_f(0.3, 0.1, t, 1.1) == 0.0);
      set.eval_rgb(0.3, 0.1, t, 1.1, rgb);
      CHECK((rgb[0] == 0.0 && rgb[1] == 0.0 && rgb[2] == 0.0));
    }
    const double below = kPi / 2 - 1e-3;
    CHECK(set.eval_f(0.3, 0.1, below, 1.1) > 0.0);
    CHECK(std::isfinite(set.eval_f(0.3, 0.1, below, 1.1)));
    CHECK(std::isfinite(set.pdf_omega(0.3, 0.1, kPi / 2, 1.1)));
    CHECK(set.pdf_omega(0.3, 0.1, kPi / 2, 1.1) == Approx(set.pdf_omega(0.3, 0.1, below, 1.1)).epsilon(0.05));
    CHECK(set.pdf_omega(0.3, 0.1, 1.7, 1.1) == 0.0);
  }
}

TEST_CASE("bsdfmix sample's stream is the header's kSampleStream", "[sample]") {
  STATIC_REQUIRE(kSampleStream == mix::kSampleStream);
  STATIC_REQUIRE(mix::kSampleStream == 0x73616d70u);
}
