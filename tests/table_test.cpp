// Table files: round trip, slice-wise reads, and every validation error.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>

#include "core/error.hpp"
#include "core/hash.hpp"
#include "core/progress.hpp"
#include "io/h5.hpp"
#include "io/inspect.hpp"
#include "io/table.hpp"

using namespace bsdfmix;
namespace fs = std::filesystem;

namespace {

std::string temp_path(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / "bsdfmix_table_test";
  fs::create_directories(dir);
  return (dir / name).string();
}

TableMeta small_meta() { return make_grid(Domain::Fiber, 3, 1, 4, 6, true); }

std::vector<float> ramp(std::size_t n) {
  std::vector<float> v(n);
  for (std::size_t i = 0; i < n; ++i) v[i] = 0.25f * float(i);
  return v;
}

// Writes a /table group bypassing TableWriter's checks, to build malformed files.
struct RawTable {
  std::string domain = "fiber", symmetry = "azimuthal", source = "{}";
  bool with_domain = true;
  std::vector<double> theta_o, phi_o, theta_i, phi_i;
  std::vector<hsize_t> dims;
  std::vector<float> values;
  explicit RawTable(const TableMeta& m) {
    theta_o = m.theta_o;
    phi_o = m.phi_o;
    theta_i = m.theta_i;
    phi_i = m.phi_i;
    dims = {theta_o.size(), phi_o.size(), theta_i.size(), phi_i.size()};
    values = ramp(m.n_slices() * m.cells_per_slice());
  }
  void write(const std::string& path) const {
    h5::Handle f = h5::create_file(path);
    h5::Handle g = h5::create_group(f.get(), "table", path);
    h5::write_doubles(g.get(), "theta_o", {theta_o.size()}, theta_o.data(), path);
    h5::write_doubles(g.get(), "phi_o", {phi_o.size()}, phi_o.data(), path);
    h5::write_doubles(g.get(), "theta_i", {theta_i.size()}, theta_i.data(), path);
    h5::write_doubles(g.get(), "phi_i", {phi_i.size()}, phi_i.data(), path);
    h5::write_floats(g.get(), "values", dims, values.data(), path);
    if (with_domain) h5::write_string_attr(g.get(), "domain", domain, path);
    h5::write_string_attr(g.get(), "symmetry", symmetry, path);
    h5::write_string_attr(g.get(), "source", source, path);
  }
};

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no error)";
}

std::string open_error(const RawTable& t, const std::string& name) {
  const std::string p = temp_path(name);
  t.write(p);
  return error_of([&] { TableReader r(p); });
}

std::string read_error(const RawTable& t, const std::string& name, std::size_t slice) {
  const std::string p = temp_path(name);
  t.write(p);
  return error_of([&] {
    TableReader r(p);
    r.read_slice(slice, 0);
  });
}

}  // namespace

TEST_CASE("a table round-trips slice by slice", "[table]") {
  TableMeta m = small_meta();
  m.source = R"({"model": "test"})";
  const auto values = ramp(m.n_slices() * m.cells_per_slice());
  const std::string p = temp_path("roundtrip.h5");
  write_table(p, m, values);
  TableReader r(p);
  CHECK(r.meta().domain == Domain::Fiber);
  CHECK(r.meta().azimuthal);
  CHECK(r.meta().source == m.source);
  CHECK(r.meta().theta_i == m.theta_i);
  CHECK(r.meta().phi_i == m.phi_i);
  for (std::size_t t = 0; t < m.theta_o.size(); ++t) {
    const auto s = r.read_slice(t, 0);
    REQUIRE(s.size() == m.cells_per_slice());
    for (std::size_t c = 0; c < s.size(); ++c) CHECK(s[c] == values[t * m.cells_per_slice() + c]);
  }
}

TEST_CASE("a non-symmetric hemisphere table with rgb round-trips", "[table]") {
  TableMeta m = make_grid(Domain::Hemisphere, 2, 4, 3, 8, false);
  m.rgb = true;
  const std::string p = temp_path("rgb.h5");
  {
    TableWriter w(p, m);
    for (std::size_t t = 0; t < 2; ++t)
      for (std::size_t q = 0; q < 4; ++q) {
        std::vector<float> v(m.cells_per_slice(), float(t * 4 + q)), rgb(3 * m.cells_per_slice());
        for (std::size_t c = 0; c < rgb.size(); ++c) rgb[c] = float(c % 3) + float(t);
        w.write_slice(t, q, v.data(), rgb.data());
      }
    w.commit();
  }
  TableReader r(p);
  CHECK(r.meta().rgb);
  CHECK_FALSE(r.meta().azimuthal);
  CHECK(r.read_slice(1, 2)[5] == 6.0f);
  CHECK(r.read_slice_rgb(1, 2)[4] == 2.0f);
  CHECK(r.meta().negative_rgb_cells == 0);
}

TEST_CASE("the writer counts the cells with a negative channel, and a rewritten slice once", "[table]") {
  TableMeta m = make_grid(Domain::Hemisphere, 2, 1, 3, 8, true);
  m.rgb = true;
  const std::string p = temp_path("rgb_negative.h5");
  const std::size_t n = m.cells_per_slice();
  std::vector<float> v(n, 1.0f), rgb(3 * n, 0.5f), clean(3 * n, 0.5f);
  rgb[0] = -1e-3f;          // cell 0: R
  rgb[3 * 5 + 2] = -2.0f;  // cell 5: B
  rgb[3 * 6 + 1] = -1.0f;  // cell 6: G and B
  rgb[3 * 6 + 2] = -1.0f;
  {
    TableWriter w(p, m);
    w.write_slice(0, 0, v.data(), rgb.data());
    w.write_slice(1, 0, v.data(), rgb.data());
    w.write_slice(1, 0, v.data(), clean.data());  // rewritten without its negative cells
    w.commit();
  }
  CHECK(TableReader(p).meta().negative_rgb_cells == 3);
  CHECK_THAT(describe_file(p, false), Catch::Contains("; 3 cells (6.2%) hold a negative channel"));
  // Without colour nothing is counted; a table written without the attribute reads -1.
  TableMeta grey = make_grid(Domain::Hemisphere, 2, 1, 3, 8, true);
  write_table(temp_path("grey.h5"), grey, std::vector<float>(grey.n_slices() * grey.cells_per_slice(), 1.0f));
  CHECK(TableReader(temp_path("grey.h5")).meta().negative_rgb_cells == -1);
  {  // an attribute that is not a count is named
    h5::Handle f(H5Fopen(p.c_str(), H5F_ACC_RDWR, H5P_DEFAULT));
    h5::Handle g(H5Gopen2(f.get(), "table", H5P_DEFAULT));
    H5Adelete(g.get(), "negative_rgb_cells");
    h5::write_string_attr(g.get(), "negative_rgb_cells", "-4", p);
  }
  CHECK_THAT(error_of([&] { TableReader r(p); }),
             Catch::Contains("attribute 'negative_rgb_cells' is '-4', not a count of cells"));
}

TEST_CASE("a compressed table with rgb round-trips, and inspect shows its colour", "[table]") {
  Progress::set_enabled(false);
  TableMeta m = make_grid(Domain::Fiber, 3, 1, 16, 32, true);
  m.rgb = true;
  const std::size_t cells = m.cells_per_slice();
  auto slice_rgb = [&](std::size_t t) {
    std::vector<float> rgb(3 * cells);
    for (std::size_t k = 0; k < cells; ++k)
      for (std::size_t c = 0; c < 3; ++c) rgb[3 * k + c] = 0.1f * float(c + 1) + 0.01f * float(t) + 1e-4f * float(k % 7);
    return rgb;
  };
  auto slice_y = [&](const std::vector<float>& rgb) {
    std::vector<float> y(cells);
    for (std::size_t k = 0; k < cells; ++k)
      y[k] = float(0.2126 * rgb[3 * k] + 0.7152 * rgb[3 * k + 1] + 0.0722 * rgb[3 * k + 2]);
    return y;
  };
  std::uintmax_t size[2] = {0, 0};
  for (int deflate : {0, 6}) {
    const std::string p = temp_path("deflate" + std::to_string(deflate) + ".h5");
    {
      TableWriter w(p, m, deflate);
      for (std::size_t t = 0; t < 3; ++t) {
        const auto rgb = slice_rgb(t);
        w.write_slice(t, 0, slice_y(rgb).data(), rgb.data());
      }
      w.commit();
    }
    size[deflate ? 1 : 0] = fs::file_size(p);
    TableReader r(p);
    REQUIRE(r.meta().rgb);
    for (std::size_t t = 0; t < 3; ++t) {
      const auto rgb = slice_rgb(t);
      CHECK(r.read_slice_rgb(t, 0) == rgb);
      CHECK(r.read_slice(t, 0) == slice_y(rgb));
    }
    const std::string text = describe_file(p, true);
    CHECK_THAT(text, Catch::Contains("the luminance of rgb") && Catch::Contains("rgb        [3, 1, 16, 32, 3] float32") &&
                         Catch::Contains("the table has colour") && Catch::Contains("colour     per-slice integral R in") &&
                         Catch::Contains("file size"));
  }
  CHECK(size[1] < size[0] / 2);  // shuffle + deflate on slowly varying floats
  CHECK_THROWS_WITH(TableWriter(temp_path("bad_deflate.h5"), m, 10), Catch::Contains("deflate level must be in [0, 9]"));
  // A table without rgb says nothing of colour.
  const std::string plain = temp_path("plain.h5");
  write_table(plain, small_meta(), ramp(small_meta().n_slices() * small_meta().cells_per_slice()));
  const std::string text = describe_file(plain, true);
  CHECK_THAT(text, !Catch::Contains("rgb") && !Catch::Contains("colour"));
}

TEST_CASE("a writer that is not committed leaves no file", "[table]") {
  const std::string p = temp_path("abandoned.h5");
  std::remove(p.c_str());
  {
    TableWriter w(p, small_meta());
    const auto v = ramp(small_meta().cells_per_slice());
    w.write_slice(0, 0, v.data());
  }
  CHECK_FALSE(fs::exists(p));
  for (const auto& e : fs::directory_iterator(fs::path(p).parent_path()))
    CHECK(e.path().filename().string().find("abandoned.h5.partial") == std::string::npos);
}

TEST_CASE("commit refuses a table with unwritten slices", "[table]") {
  const std::string p = temp_path("incomplete.h5");
  std::remove(p.c_str());
  TableWriter w(p, small_meta());
  const auto v = ramp(small_meta().cells_per_slice());
  w.write_slice(0, 0, v.data());
  CHECK_THROWS_WITH(w.commit(), Catch::Contains("slice (theta_o 1, phi_o 0) was never written"));
  CHECK_FALSE(fs::exists(p));
}

TEST_CASE("bad cells are named by slice and cell", "[table][validation]") {
  const TableMeta m = small_meta();
  RawTable t(m);
  const std::size_t cells = m.cells_per_slice();
  t.values[1 * cells + 2 * 6 + 3] = std::numeric_limits<float>::quiet_NaN();
  CHECK_THAT(read_error(t, "nan.h5", 1), Catch::Contains("slice (theta_o 1, phi_o 0) cell (theta_i 2, phi_i 3): NaN"));
  t = RawTable(m);
  t.values[2 * cells + 5] = std::numeric_limits<float>::infinity();
  CHECK_THAT(read_error(t, "inf.h5", 2), Catch::Contains("cell (theta_i 0, phi_i 5): Inf"));
  t = RawTable(m);
  t.values[7] = -0.5f;
  CHECK_THAT(read_error(t, "neg.h5", 0), Catch::Contains("cell (theta_i 1, phi_i 1): negative value -0.5"));
  // Other slices of the same file still read: only the slice read is checked.
  CHECK(read_error(t, "neg2.h5", 1) == "(no error)");
}

TEST_CASE("structural errors are rejected with what and where", "[table][validation]") {
  const TableMeta m = small_meta();
  RawTable t(m);
  t.theta_i[2] += 0.05;
  CHECK_THAT(open_error(t, "nonuniform.h5"), Catch::Contains("axis theta_i is not uniformly spaced (cells 1..2"));

  t = RawTable(m);
  for (double& x : t.theta_i) x += 0.3;
  CHECK_THAT(open_error(t, "outside.h5"), Catch::Contains("axis theta_i cell 3") && Catch::Contains("outside the domain"));

  t = RawTable(m);
  t.domain = "hemisphere";  // fiber axes (negative theta) in a hemisphere table
  CHECK_THAT(open_error(t, "outside_hemi.h5"), Catch::Contains("outside the domain"));

  t = RawTable(m);
  t.phi_i = uniform_centers(-kPi, 0, 6);
  CHECK_THAT(open_error(t, "halfphi.h5"), Catch::Contains("axis phi_i must cover the full period"));

  t = RawTable(m);
  t.domain = "sphere";
  CHECK_THAT(open_error(t, "domain.h5"), Catch::Contains("unknown domain 'sphere'"));

  t = RawTable(m);
  t.with_domain = false;
  CHECK_THAT(open_error(t, "nodomain.h5"), Catch::Contains("/table: missing attribute 'domain'"));

  t = RawTable(m);
  t.symmetry = "radial";
  CHECK_THAT(open_error(t, "symmetry.h5"), Catch::Contains("unknown symmetry 'radial'"));

  t = RawTable(m);
  t.dims = {3, 24};
  t.values.resize(72);
  CHECK_THAT(open_error(t, "rank.h5"), Catch::Contains("/table/values: rank 2, expected 4"));

  t = RawTable(m);
  t.dims = {3, 1, 6, 4};
  CHECK_THAT(open_error(t, "shape.h5"), Catch::Contains("shape [3, 1, 6, 4] does not match the axes [3, 1, 4, 6]"));

  t = RawTable(m);
  t.phi_o = {0.5};
  CHECK_THAT(open_error(t, "phio.h5"), Catch::Contains("symmetry 'azimuthal' requires phi_o = [0]"));
}

TEST_CASE("files that are not tables are rejected", "[table][validation]") {
  CHECK_THAT(error_of([] { TableReader r(temp_path("does_not_exist.h5")); }),
             Catch::Contains("does_not_exist.h5: no such file"));

  const std::string text = temp_path("text.h5");
  std::ofstream(text) << "this is not HDF5\n";
  CHECK_THAT(error_of([&] { TableReader r(text); }), Catch::Contains("not an HDF5 file"));

  // A real table cut in half.
  const std::string full = temp_path("full.h5"), cut = temp_path("truncated.h5");
  TableMeta big = make_grid(Domain::Fiber, 8, 1, 32, 64, true);
  write_table(full, big, ramp(big.n_slices() * big.cells_per_slice()));
  {
    std::ifstream in(full, std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), {});
    std::ofstream(cut, std::ios::binary).write(bytes.data(), std::streamsize(bytes.size() / 2));
  }
  const std::string e = error_of([&] {
    TableReader r(cut);
    for (std::size_t s = 0; s < 8; ++s) r.read_slice(s, 0);
  });
  CHECK_THAT(e, Catch::Contains("truncated.h5"));
  CHECK(e != "(no error)");

  // An HDF5 file without a /table group.
  const std::string empty = temp_path("empty.h5");
  { h5::Handle f = h5::create_file(empty); }
  CHECK_THAT(error_of([&] { TableReader r(empty); }), Catch::Contains("missing group /table"));
}

TEST_CASE("integrand weights follow the domain's measure", "[table][domain]") {
  // f = 1 everywhere: the weights sum to the measure of the domain.
  const TableMeta fiber = make_grid(Domain::Fiber, 1, 1, 90, 180, true);
  std::vector<float> ones(fiber.cells_per_slice(), 1.0f);
  double sum = 0;
  for (double w : integrand_weights(Domain::Fiber, fiber.theta_i, fiber.phi_i, ones.data())) sum += w;
  CHECK(sum == Approx(4 * kPi).epsilon(1e-4));  // sphere: integral of cos(theta) dtheta dphi
  const TableMeta hemi = make_grid(Domain::Hemisphere, 1, 1, 90, 180, true);
  sum = 0;
  for (double w : integrand_weights(Domain::Hemisphere, hemi.theta_i, hemi.phi_i, ones.data())) sum += w;
  CHECK(sum == Approx(kPi).epsilon(1e-4));  // hemisphere: integral of cos sin dtheta dphi = pi
  CHECK(wrap_phi(kPi) == Approx(-kPi));
  CHECK(wrap_phi(3 * kPi + 0.5) == Approx(-kPi + 0.5));
  CHECK(wrap_phi(-kPi - 0.25) == Approx(kPi - 0.25));
}

TEST_CASE("hash_file_bytes gives hash_file's value", "[table][hash]") {
  for (const std::size_t n : {std::size_t(0), std::size_t(7), std::size_t(1) << 20, (std::size_t(1) << 20) + 5,
                              std::size_t(2) << 20}) {
    INFO("bytes: " << n);
    std::string bytes(n, '\0');
    for (std::size_t i = 0; i < n; ++i) bytes[i] = char((i * 131 + 7) & 0xff);
    const std::string p = temp_path("hash_" + std::to_string(n) + ".bin");
    std::ofstream(p, std::ios::binary).write(bytes.data(), std::streamsize(n));
    CHECK(hash_file_bytes(bytes) == hash_file(p));
    if (n > 0) {
      bytes[n / 2] = char(bytes[n / 2] ^ 1);
      CHECK(hash_file_bytes(bytes) != hash_file(p));
    }
  }
}

TEST_CASE("a table loaded once reads as the file does", "[table]") {
  TableMeta m = make_grid(Domain::Hemisphere, 3, 1, 5, 8, true);
  m.rgb = true;
  const std::string p = temp_path("loaded.h5");
  {
    TableWriter w(p, m);
    for (std::size_t t = 0; t < 3; ++t) {
      const std::vector<float> v = ramp(m.cells_per_slice()), rgb = ramp(3 * m.cells_per_slice());
      w.write_slice(t, 0, v.data(), rgb.data());
    }
    w.commit();
  }
  const LoadedTable loaded = load_table(p);
  const TableReader disk(p);
  CHECK(loaded.file_hash == hash_file(p));
  CHECK(loaded.reader.path() == p);
  CHECK(loaded.reader.meta().theta_o == disk.meta().theta_o);
  CHECK(loaded.reader.meta().phi_i == disk.meta().phi_i);
  CHECK(loaded.reader.meta().domain == Domain::Hemisphere);
  CHECK(loaded.reader.meta().rgb);
  for (std::size_t t = 0; t < 3; ++t) {
    CHECK(loaded.reader.read_slice(t, 0) == disk.read_slice(t, 0));
    CHECK(loaded.reader.read_slice_rgb(t, 0) == disk.read_slice_rgb(t, 0));
  }
  // the file gone, the loaded table still reads
  const std::string moved = temp_path("loaded_moved.h5");
  fs::rename(p, moved);
  CHECK(loaded.reader.read_slice(2, 0) == disk.read_slice(2, 0));

  CHECK_THAT(error_of([] { load_table(temp_path("no_such_table.h5")); }),
             Catch::Contains("no_such_table.h5: no such file"));
  const std::string text = temp_path("loaded_text.h5");
  std::ofstream(text) << "this is not HDF5\n";
  CHECK_THAT(error_of([&] { load_table(text); }), Catch::Contains("not an HDF5 file"));
  const std::string empty = temp_path("loaded_empty.h5");
  { h5::Handle f = h5::create_file(empty); }
  CHECK_THAT(error_of([&] { load_table(empty); }), Catch::Contains("missing group /table"));
}
