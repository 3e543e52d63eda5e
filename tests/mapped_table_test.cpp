// The full-4D table, memory-mapped (render/mapped_table.hpp, render/full_f.hpp): the same
// f as TableReader at every cell, bilinear between slices, the fiber's reference frame at
// a hit, and one-line errors for tables it cannot map.
#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "core/progress.hpp"
#include "io/table.hpp"
#include "render/bsdf.hpp"
#include "render/full_f.hpp"
#include "render/mapped_table.hpp"
#include "tables/fiber_generator.hpp"

using namespace bsdfmix;
using namespace bsdfmix::render;
namespace fs = std::filesystem;

namespace {

std::string temp_path(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / "bsdfmix_mapped_table_test";
  fs::create_directories(dir);
  return (dir / name).string();
}

// A tiny generated fiber table: full-4D (symmetry off) or azimuthal, optionally compressed.
std::string fiber_table(const std::string& name, bool symmetry, int deflate = 0) {
  Progress::set_enabled(false);
  FiberGenerateOptions opt;
  opt.preset = "wool";
  opt.n_theta_o = 6;
  opt.n_theta_i = 8;
  opt.n_phi_i = 12;
  opt.symmetry = symmetry;
  opt.n_phi_o = symmetry ? 1 : 5;
  opt.noise = 0.1;
  opt.seed = 3;
  opt.deflate = deflate;
  const std::string path = temp_path(name);
  fs::remove(path);
  generate_fiber_table(opt, "", path);
  return path;
}

}  // namespace

TEST_CASE("the mapped table gives TableReader's value at every cell, and blends between slices", "[render]") {
  const std::string path = fiber_table("full4d.h5", false);
  const TableReader reader(path);
  const MappedTable mapped(path);
  const TableMeta& m = reader.meta();
  REQUIRE(mapped.meta().n_slices() == 30);
  const std::size_t np = m.phi_i.size();
  bool any_positive = false, columns_differ = false;
  for (std::size_t t = 0; t < m.theta_o.size(); ++t)
    for (std::size_t p = 0; p < m.phi_o.size(); ++p) {
      const std::vector<float> v = reader.read_slice(t, p);
      const std::vector<float> v0 = reader.read_slice(t, 0);
      for (std::size_t i = 0; i < m.theta_i.size(); ++i)
        for (std::size_t j = 0; j < np; ++j) {
          const float x = v[i * np + j];
          REQUIRE(mapped.cell(t, p, i, j) == x);
          REQUIRE(mapped.f(m.theta_o[t], m.phi_o[p], m.theta_i[i], m.phi_i[j]) == double(x));
          any_positive = any_positive || x > 0;
          columns_differ = columns_differ || x != v0[i * np + j];
        }
    }
  CHECK(any_positive);
  CHECK(columns_differ);  // a table without symmetry: phi_o matters
  // halfway between two theta_o rows, and between the last phi_o column and the first (wrapping)
  const double to = 0.5 * (m.theta_o[2] + m.theta_o[3]);
  const double po = m.phi_o.back() + 0.5 * (m.phi_o[1] - m.phi_o[0]);
  for (std::size_t i = 0; i < m.theta_i.size(); ++i) {
    const double a = mapped.cell(2, 1, i, 4), b = mapped.cell(3, 1, i, 4);
    CHECK(mapped.f(to, m.phi_o[1], m.theta_i[i], m.phi_i[4]) == Approx(0.5 * (a + b)).epsilon(1e-12));
    const double c = mapped.cell(0, 4, i, 7), d = mapped.cell(0, 0, i, 7);
    CHECK(mapped.f(m.theta_o[0], po, m.theta_i[i], m.phi_i[7]) == Approx(0.5 * (c + d)).epsilon(1e-12));
  }
  CHECK(mapped.table_bytes() == 30u * 8 * 12 * 4);
  CHECK(mapped.mapped_bytes() >= mapped.table_bytes());
  CHECK(mapped.resident_bytes() > 0);  // the cells read above
}

TEST_CASE("at a fiber hit, f comes from the mapped table at omega_o's and omega_i's reference azimuths", "[render]") {
  const std::string az = fiber_table("azimuthal.h5", true), path = fiber_table("full4d_hit.h5", false);
  const TableBsdf sampler(az);
  FullF full;
  full.table = std::make_unique<MappedTable>(path);
  TableBsdf with_full(az);
  with_full.set_full(&full);
  PathStrategy st;
  st.technique = BsdfSampler::Uniform;
  const SampledBxdf bxdf(with_full, FSource::Table, st), plain(sampler, FSource::Table, st);
  Hit hit;
  hit.kind = HitKind::Fiber;
  const Vec3 t = normalized({0.3, 0.8, 0.2}), wo = normalized({0.5, -0.4, 0.7}), wi = normalized({-0.6, 0.1, 0.3});
  hit.tangent = t;
  VertexBsdf held, held_plain;
  const Bsdf& b = held.at(hit, wo, bxdf, 0.5);
  const double theta_o = std::asin(dot(wo, t)), theta_i = std::asin(dot(wi, t));
  const double want = full.table->f(theta_o, reference_phi(t, wo), theta_i, reference_phi(t, wi));
  CHECK(want > 0);
  CHECK(b.f(wi)[0] == Approx(want).epsilon(1e-9));
  // the reference e1 is +z made perpendicular to t: its azimuth is 0, e2 = t x e1 at pi / 2
  const Vec3 e1 = normalized({-t[2] * t[0], -t[2] * t[1], 1 - t[2] * t[2]});
  CHECK(reference_phi(t, e1) == Approx(0).margin(1e-12));
  CHECK(reference_phi(t, cross(t, e1)) == Approx(kPi / 2).epsilon(1e-12));
  // without a full table the azimuthal path is as before
  const Bsdf& p = held_plain.at(hit, wo, plain, 0.5);
  double th, ph;
  local_angles(p.axes(), wi, th, ph);
  CHECK(p.f(wi)[0] == sampler.f_rgb(FSource::Table, p.theta_o(), th, ph)[0]);
}

TEST_CASE("the mapped table refuses an azimuthal, a compressed or a hemisphere table in one line", "[render]") {
  CHECK_THROWS_WITH(MappedTable(fiber_table("sym.h5", true)), Catch::Contains("without symmetry"));
  CHECK_THROWS_WITH(MappedTable(fiber_table("deflate.h5", false, 1)), Catch::Contains("compressed"));
  const std::string hemi = temp_path("hemi.h5");
  const TableMeta m = make_grid(Domain::Hemisphere, 3, 4, 4, 8, false);
  write_table(hemi, m, std::vector<float>(m.n_slices() * m.cells_per_slice(), 1.0f));
  CHECK_THROWS_WITH(MappedTable(hemi), Catch::Contains("needs a fiber table"));
  CHECK_THROWS_AS(MappedTable(temp_path("missing.h5")), InputError);
  for (const std::string& p : {fiber_table("sym2.h5", true), hemi}) {
    try {
      const MappedTable t(p);
      FAIL("no error");
    } catch (const InputError& e) {
      CHECK(std::string(e.what()).find('\n') == std::string::npos);
      CHECK_THAT(e.what(), Catch::StartsWith(p));
    }
  }
}
