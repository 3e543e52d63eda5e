// Mixture file storage: padded and ragged layouts, rgb_scale as float64 or float32; the
// bytes each stores; old files; the header's blend of files fitted on every k-th slice.
#include <catch2/catch.hpp>

#include <hdf5.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "core/error.hpp"
#include "io/mixture_file.hpp"

using namespace bsdfmix;
namespace fs = std::filesystem;

namespace {

std::string temp_path(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / "bsdfmix_storage_test";
  fs::create_directories(d);
  return (d / name).string();
}

// The storage sizes of every dataset of /mixture.
std::uint64_t stored_bytes(const std::string& path) {
  const hid_t file = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  const hid_t group = H5Gopen2(file, "mixture", H5P_DEFAULT);
  std::uint64_t stored = 0;
  H5Literate(group, H5_INDEX_NAME, H5_ITER_NATIVE, nullptr,
             [](hid_t g, const char* name, const H5L_info_t*, void* acc) -> herr_t {
               const hid_t d = H5Dopen2(g, name, H5P_DEFAULT);
               if (d >= 0) {
                 *static_cast<std::uint64_t*>(acc) += H5Dget_storage_size(d);
                 H5Dclose(d);
               }
               return 0;
             },
             &stored);
  H5Gclose(group);
  H5Fclose(file);
  return stored;
}

bool has_dataset(const std::string& path, const char* name) {
  const hid_t file = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  const bool r = H5Lexists(file, name, H5P_DEFAULT) > 0;
  H5Fclose(file);
  return r;
}

// Three slices of K 1, 3 and 2 on every 2nd slice of a 5-slice theta_o grid, with colour
// (and colour copies on the middle slice).
MixtureFile sample_file(bool rgb, bool copies = false) {
  MixtureFile m;
  m.domain = Domain::Hemisphere;
  m.table_theta_o = {0.1, 0.4, 0.7, 1.0, 1.3};
  m.table_phi_o = {0.0};
  const std::vector<double> r1 = {0.1, 0.2, 0.3};
  const std::vector<double> r3 = {0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 0.123456789012, 0.2, 0.3};
  const std::vector<double> r2 = {0.3, 0.2, 0.1, 0.05, 0.06, 0.07};
  m.add_slice(0.1, 0, 1.0, -1, 0.1, {1.0}, {0.5, 0.0}, {0.1, 0.0, 0.2}, rgb ? &r1 : nullptr);
  std::vector<double> c3;
  for (int i = 0; copies && i < 36; ++i) c3.push_back(0.01 * (1 + i % 7) + 0.000123456789 * i);
  m.add_slice(0.7, 0, 2.0, -1, 0.1, {0.5, 0.3, 0.2}, {0.5, 0.0, 0.7, 1.0, 1.2, -2.0},
              {0.1, 0.0, 0.2, 0.1, 0.01, 0.2, 0.05, -0.01, 0.3}, rgb ? &r3 : nullptr, &c3);
  m.add_slice(1.3, 0, 0.5, -1, 0.1, {0.6, 0.4}, {0.9, 0.3, 0.2, -0.5}, {0.02, 0.0, 0.1, 0.2, 0.05, 0.4},
              rgb ? &r2 : nullptr);
  return m;
}

const MixtureStorage kAll[] = {{false, false}, {true, false}, {false, true}, {true, true}};

}  // namespace

TEST_CASE("storage names parse and print", "[storage]") {
  for (const auto& s : kAll) CHECK(parse_storage(storage_name(s), "test") == s);
  CHECK(storage_name({true, true}) == "ragged_f32");
  CHECK_THROWS_AS(parse_storage("compact", "test"), InputError);
}

TEST_CASE("padded and ragged files of the same mixtures read back alike; payload_bytes is what each stores",
          "[storage]") {
  for (const int variant : {0, 1, 2}) {
    const bool rgb = variant >= 1, copies = variant == 2;
    const MixtureFile m = sample_file(rgb, copies);
    CHECK(m.has_copies() == copies);
    const mix::MixtureSet ref = to_mixture_set(m);
    std::uint64_t padded_bytes = 0, ragged_bytes = 0;
    for (const auto& st : kAll) {
      INFO("rgb " << rgb << " storage " << storage_name(st));
      MixtureFile w = m;
      w.storage = st;
      const std::string path = temp_path("s_" + storage_name(st) + (rgb ? "_rgb" : "") + (copies ? "_copies" : "") + ".h5");
      write_mixture_file(path, w);
      CHECK(has_dataset(path, "/mixture/offset") == st.ragged);
      const MixtureFile r = read_mixture_file(path);
      CHECK(r.storage.ragged == st.ragged);
      CHECK(r.storage.float32 == (rgb && st.float32));  // without colour nothing tells float32 apart
      CHECK(w.payload_bytes() == stored_bytes(path));
      CHECK(r.payload_bytes() == stored_bytes(path));
      (st.ragged ? ragged_bytes : padded_bytes) = w.payload_bytes();
      // The same padded arrays in memory.
      CHECK(r.kmax == m.kmax);
      CHECK(r.k == m.k);
      CHECK(r.weights == m.weights);
      CHECK(r.means == m.means);
      CHECK(r.covariances == m.covariances);
      CHECK(r.scale == m.scale);
      CHECK(r.table_theta_o == m.table_theta_o);
      REQUIRE(r.rgb_scale.size() == m.rgb_scale.size());
      for (std::size_t i = 0; i < m.rgb_scale.size(); ++i) {
        if (st.float32) CHECK(r.rgb_scale[i] == double(float(m.rgb_scale[i])));  // float rounding, no more
        else CHECK(r.rgb_scale[i] == m.rgb_scale[i]);
      }
      REQUIRE(r.rgb_copies.size() == m.rgb_copies.size());
      for (std::size_t i = 0; i < m.rgb_copies.size(); ++i) {
        if (st.float32) CHECK(r.rgb_copies[i] == double(float(m.rgb_copies[i])));
        else CHECK(r.rgb_copies[i] == m.rgb_copies[i]);
      }
      CHECK(r.slice_copies(0).empty());
      CHECK(r.slice_copies(1).size() == (copies ? 36u : 0u));
      // The same stand-in, at fitted and blended slices alike.
      const mix::MixtureSet set = to_mixture_set(r);
      REQUIRE(set.slices.size() == ref.slices.size());
      for (const double to : {0.1, 0.4, 0.55, 0.7, 1.0, 1.3})
        for (const double t : {0.2, 0.6, 1.1})
          for (const double p : {-2.0, 0.0, 0.4}) {
            CHECK(set.eval_f(to, 0, t, p) == ref.eval_f(to, 0, t, p));
            double a[3], b[3];
            set.eval_rgb(to, 0, t, p, a);
            ref.eval_rgb(to, 0, t, p, b);
            for (int c = 0; c < 3; ++c) {
              if (st.float32) CHECK(a[c] == Approx(b[c]).epsilon(1e-6).margin(1e-300));
              else CHECK(a[c] == b[c]);
            }
          }
      // Written again, a read file keeps its storage.
      write_mixture_file(path, r);
      CHECK(read_mixture_file(path).storage == r.storage);
    }
    // Ragged stores sum k = 6 components instead of S * Kmax = 9.
    CHECK(ragged_bytes < padded_bytes);
  }
}

TEST_CASE("a ragged file with offsets that do not follow k is refused", "[storage]") {
  MixtureFile m = sample_file(true);
  m.storage.ragged = true;
  const std::string path = temp_path("bad_offset.h5");
  write_mixture_file(path, m);
  {
    const hid_t file = H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    const hid_t d = H5Dopen2(file, "/mixture/offset", H5P_DEFAULT);
    const std::int32_t bad[3] = {0, 2, 4};
    H5Dwrite(d, H5T_NATIVE_INT32, H5S_ALL, H5S_ALL, H5P_DEFAULT, bad);
    H5Dclose(d);
    H5Fclose(file);
  }
  CHECK_THROWS_WITH(read_mixture_file(path), Catch::Contains("offset: slice 1 starts at 2, expected 1"));
}

TEST_CASE("an old padded file still reads, and payload_bytes is what it stores", "[storage]") {
  const std::string old = std::string(BSDFMIX_TEST_DATA) + "/mixture_before_rgb.h5";
  const MixtureFile m = read_mixture_file(old);
  CHECK_FALSE(m.storage.ragged);
  // what a write stores: the file's datasets and the `defensive` it lacks
  CHECK(m.payload_bytes() == stored_bytes(old) + m.slices() * sizeof(double));
  MixtureFile r = m;
  r.storage = {true, true};
  const std::string path = temp_path("old_ragged.h5");
  write_mixture_file(path, r);
  const MixtureFile back = read_mixture_file(path);
  CHECK(back.weights == m.weights);
  CHECK(back.payload_bytes() == stored_bytes(path));
}

TEST_CASE("a file fitted on every 2nd slice is blended linearly between its fitted slices", "[storage]") {
  const MixtureFile m = sample_file(true);
  const mix::MixtureSet set = to_mixture_set(m);
  // The table's slice 1 (theta_o 0.4) lies halfway between fitted slices 0 and 2.
  auto b = set.blend(0.4, 0);
  REQUIRE(b.count == 2);
  CHECK(b.weight[0] == Approx(0.5));
  CHECK(b.weight[1] == Approx(0.5));
  // theta_o 0.55: a quarter of the way from 0.4 to 0.7, so 3/4 of the way from 0.1 to 0.7.
  b = set.blend(0.55, 0);
  REQUIRE(b.count == 2);
  CHECK(b.slice[0] == 0);
  CHECK(b.weight[0] == Approx(0.25));
  CHECK(b.weight[1] == Approx(0.75));
  const double t = 0.6, p = 0.3;
  CHECK(set.eval_f(1.0, 0, t, p) ==
        Approx(0.5 * set.eval_f(0.7, 0, t, p) + 0.5 * set.eval_f(1.3, 0, t, p)).epsilon(1e-12));
  // At a fitted slice, that slice alone; beyond the grid, the end slice.
  b = set.blend(0.7, 0);
  CHECK(b.count == 1);
  CHECK(b.slice[0] == 1);
  b = set.blend(1.5, 0);
  CHECK(b.count == 1);
  CHECK(b.slice[0] == 2);
  // Only the last slices fitted: below them, the lowest fitted one.
  MixtureFile tail;
  tail.domain = Domain::Hemisphere;
  tail.table_theta_o = m.table_theta_o;
  tail.table_phi_o = {0.0};
  tail.add_slice(1.0, 0, 1.0, -1, 0.1, {1.0}, {0.5, 0.0}, {0.1, 0.0, 0.2});
  tail.add_slice(1.3, 0, 1.0, -1, 0.1, {1.0}, {0.6, 0.0}, {0.1, 0.0, 0.2});
  const mix::MixtureSet ts = to_mixture_set(tail);
  b = ts.blend(0.1, 0);
  CHECK(b.count == 1);
  CHECK(b.slice[0] == 0);
}

TEST_CASE("bsdfmix pack writes the same mixtures in the storage asked for", "[storage]") {
  const MixtureFile m = sample_file(true);
  const std::string in = temp_path("pack_in.h5"), out = temp_path("pack_out.h5");
  write_mixture_file(in, m);
  const std::string cmd = std::string(BSDFMIX_BINARY) + " pack " + in + " -o " + out + " --quiet > " +
                          temp_path("pack.log") + " 2>&1";
  REQUIRE(std::system(cmd.c_str()) == 0);
  const MixtureFile r = read_mixture_file(out);
  // the line gives the file's bytes beside the payload's, before and after (the payload last)
  std::ifstream log(temp_path("pack.log"));
  const std::string line((std::istreambuf_iterator<char>(log)), {});
  CHECK_THAT(line, Catch::Contains(": file " + std::to_string(std::filesystem::file_size(in)) + " -> " +
                                   std::to_string(std::filesystem::file_size(out)) + " bytes, payload " +
                                   std::to_string(m.payload_bytes()) + " -> " + std::to_string(r.payload_bytes()) +
                                   " bytes\n"));
  CHECK(r.storage == MixtureStorage{true, true});  // the default, ragged_f32
  CHECK(r.weights == m.weights);
  CHECK(r.fit_settings == m.fit_settings);
  CHECK(r.payload_bytes() == stored_bytes(out));
  CHECK(r.payload_bytes() < m.payload_bytes());
  const std::string bad = std::string(BSDFMIX_BINARY) + " pack " + in + " -o " + out + " --storage tiny > " +
                          temp_path("pack_bad.log") + " 2>&1";
  CHECK(std::system(bad.c_str()) != 0);
}
