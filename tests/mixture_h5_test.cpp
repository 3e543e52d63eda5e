// The header loader (include/bsdfmix/mixture_h5.hpp, load_mixture_h5) against bsdfmix's own
// reader (read_mixture_file + to_mixture_set): the same MixtureSet, bit for bit in eval_f,
// eval_rgb, pdf_omega and sample_counter, on files of every storage, colour (none, rgb,
// copies), map (theta_phi, disk with a base, cylinder), interpolation and symmetry, on a
// version-1 file and on fixed-length ASCII attributes; and a one-line error naming the file
// and the object for a missing, foreign, truncated, newer or damaged file.
// labels: io
#include <catch2/catch.hpp>

#include <bsdfmix/mixture_h5.hpp>
#include <hdf5.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>

#include "core/domain.hpp"
#include "io/mixture_file.hpp"

using namespace bsdfmix;
namespace fs = std::filesystem;

namespace {

std::string temp_path(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / "bsdfmix_mixture_h5_test";
  fs::create_directories(d);
  return (d / name).string();
}

struct Variant {
  Domain domain = Domain::Hemisphere;
  Map map = Map::ThetaPhi;
  bool rgb = false, copies = false, base = false, azimuthal = true;
  mix::Interpolation interpolation = mix::Interpolation::Blend;
  MixtureStorage storage;
  std::string name() const {
    return domain_name(domain) + "_" + map_name(map) + (rgb ? "_rgb" : "") + (copies ? "_copies" : "") +
           (base ? "_base" : "") + (azimuthal ? "" : "_nosym") +
           (interpolation == mix::Interpolation::Displace ? "_displace" : "") + "_" + storage_name(storage);
  }
};

// Slices of K 1..3 on theta_o rows 0, 2, 4 of a 5-row grid (and both phi_o columns of a
// 2-column grid without symmetry), random components inside the map.
MixtureFile make_file(const Variant& v, unsigned seed) {
  std::mt19937 rng(seed);
  auto u = [&](double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng); };
  MixtureFile m;
  m.domain = v.domain;
  m.map = v.map;
  m.azimuthal = v.azimuthal;
  m.interpolation = v.interpolation;
  m.storage = v.storage;
  const bool hemi = v.domain == Domain::Hemisphere;
  m.table_theta_o = hemi ? std::vector<double>{0.1, 0.4, 0.7, 1.0, 1.3} : std::vector<double>{-1.2, -0.6, 0.0, 0.6, 1.2};
  m.table_phi_o = v.azimuthal ? std::vector<double>{0.0} : uniform_centers(-kPi, kPi, 2);
  for (const std::size_t t : {0, 2, 4})
    for (const double phi_o : m.table_phi_o) {
      const int k = 1 + int(rng() % 3);
      const double base = v.base && (t != 2) ? 0.2 : 0.0;
      std::vector<double> w, mean, cov, rgb, copies;
      for (int j = 0; j < k; ++j) {
        w.push_back((1 - base) / k);
        if (v.map == Map::Disk) mean.insert(mean.end(), {u(-0.9, 0.9), u(-0.9, 0.9)});
        else if (v.map == Map::Cylinder) mean.insert(mean.end(), {u(-0.8, 0.8), u(-3, 3)});
        else mean.insert(mean.end(), {hemi ? u(0.1, 1.4) : u(-1.2, 1.2), u(-3, 3)});
        const double st = u(0.1, 0.4), sp = u(0.1, 0.6), rho = u(-0.5, 0.5);
        cov.insert(cov.end(), {st * st, rho * st * sp, sp * sp});
        for (int c = 0; c < 3; ++c) rgb.push_back(u(0.05, 1.0));
      }
      for (int i = 0; v.copies && t != 2 && i < 12 * k; ++i) copies.push_back(u(0.01, 0.5));
      m.add_slice(m.table_theta_o[t], phi_o, u(0.2, 2.0), -1, 0.1, w, mean, cov, v.rgb ? &rgb : nullptr, &copies);
      const double brgb[3] = {u(0.01, 0.2), u(0.01, 0.2), u(0.01, 0.2)};
      if (base > 0) m.set_base(base, brgb);
      m.defensive.back() = u(0.0, 0.1);
    }
  return m;
}

// eval_f, eval_rgb, pdf_omega and sample_counter of a and b agree exactly at many points.
void check_same(const mix::MixtureSet& a, const mix::MixtureSet& b, unsigned seed) {
  std::mt19937 rng(seed);
  auto u = [&](double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng); };
  const double lo = mix::theta_lo(a.domain), hi = mix::theta_hi(a.domain);
  int differ = 0;
  for (int i = 0; i < 400; ++i) {
    const double to = u(a.grid_theta_o.front() - 0.1, a.grid_theta_o.back() + 0.1), po = u(-kPi, kPi);
    const double t = u(lo, hi), p = u(-kPi, kPi);
    differ += a.eval_f(to, po, t, p) != b.eval_f(to, po, t, p);
    differ += a.pdf_omega(to, po, t, p) != b.pdf_omega(to, po, t, p);
    double ra[3], rb[3];
    a.eval_rgb(to, po, t, p, ra);
    b.eval_rgb(to, po, t, p, rb);
    for (int c = 0; c < 3; ++c) differ += ra[c] != rb[c];
    const mix::Sample sa = a.sample_counter(to, po, 7, mix::kSampleStream, std::uint64_t(i));
    const mix::Sample sb = b.sample_counter(to, po, 7, mix::kSampleStream, std::uint64_t(i));
    differ += sa.valid != sb.valid || (sa.valid && (sa.theta != sb.theta || sa.phi != sb.phi || sa.pdf_omega != sb.pdf_omega));
    differ += a.defensive(to, po) != b.defensive(to, po);
  }
  CHECK(differ == 0);
  CHECK(a.slices.size() == b.slices.size());
  CHECK(a.map == b.map);
  CHECK(a.azimuthal == b.azimuthal);
  CHECK(a.interpolation == b.interpolation);
  CHECK(a.grid_theta_o == b.grid_theta_o);
  CHECK(a.grid_phi_o == b.grid_phi_o);
  for (std::size_t s = 0; s < a.slices.size() && s < b.slices.size(); ++s) {
    CHECK(a.slices[s].colour.size() == b.slices[s].colour.size());
    CHECK(a.slices[s].base == b.slices[s].base);
    CHECK(a.slices[s].has_rgb == b.slices[s].has_rgb);
  }
}

// Opens /mixture of a file for writing.
struct Group {
  hid_t file, group;
  explicit Group(const std::string& path)
      : file(H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT)), group(H5Gopen2(file, "mixture", H5P_DEFAULT)) {
    REQUIRE(group >= 0);
  }
  ~Group() {
    H5Gclose(group);
    H5Fclose(file);
  }
};

// Rewrites string attribute `name` as a fixed-length ASCII string (as h5py writes numpy bytes).
void fixed_length_attr(hid_t g, const char* name, const std::string& value) {
  if (H5Aexists(g, name) > 0) H5Adelete(g, name);
  const hid_t type = H5Tcopy(H5T_C_S1);
  H5Tset_size(type, value.size());
  H5Tset_strpad(type, H5T_STR_NULLPAD);
  const hid_t space = H5Screate(H5S_SCALAR);
  const hid_t a = H5Acreate2(g, name, type, space, H5P_DEFAULT, H5P_DEFAULT);
  REQUIRE(H5Awrite(a, type, value.data()) >= 0);
  H5Aclose(a);
  H5Sclose(space);
  H5Tclose(type);
}

// The loader's error message for `path` ("" when it loads).
std::string load_error(const std::string& path) {
  try {
    mix::load_mixture_h5(path);
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

std::string written(const std::string& name, const Variant& v = {}) {
  const std::string path = temp_path(name);
  write_mixture_file(path, make_file(v, 11));
  return path;
}

}  // namespace

TEST_CASE("the header loader gives bsdfmix's MixtureSet on every storage, colour, map, base, interpolation and symmetry",
          "[io]") {
  const MixtureStorage storages[] = {{false, false}, {true, false}, {false, true}, {true, true}};
  const std::pair<Domain, Map> planes[] = {{Domain::Hemisphere, Map::ThetaPhi}, {Domain::Hemisphere, Map::Disk},
                                           {Domain::Fiber, Map::ThetaPhi}, {Domain::Fiber, Map::Cylinder}};
  unsigned seed = 1;
  int files = 0;
  for (const auto& [domain, map] : planes)
    for (const int colour : {0, 1, 2})
      for (const bool azimuthal : {true, false})
        for (const auto interpolation : {mix::Interpolation::Blend, mix::Interpolation::Displace})
          for (const auto& storage : storages) {
            Variant v;
            v.domain = domain;
            v.map = map;
            v.rgb = colour >= 1;
            v.copies = colour == 2;
            v.base = map == Map::Disk;
            v.azimuthal = azimuthal;
            v.interpolation = interpolation;
            v.storage = storage;
            INFO(v.name());
            const std::string path = temp_path(v.name() + ".h5");
            write_mixture_file(path, make_file(v, ++seed));
            const mix::MixtureSet ours = mix::load_mixture_h5(path);
            check_same(ours, to_mixture_set(read_mixture_file(path)), seed);
            CHECK(ours.slices.front().has_rgb == v.rgb);
            CHECK(!ours.slices.front().colour.empty() == v.copies);
            CHECK((ours.slices.front().base > 0) == v.base);
            ++files;
          }
  CHECK(files == 4 * 3 * 2 * 2 * 4);
}

TEST_CASE("the header loader reads a version-1 file and fixed-length ASCII attributes as bsdfmix does", "[io]") {
  Variant v;
  v.rgb = v.copies = true;
  const std::string path = written("old.h5", v);
  {
    Group g(path);
    for (const char* name : {"format_version", "map", "interpolation"})
      if (H5Aexists(g.group, name) > 0) H5Adelete(g.group, name);
    for (const char* name : {"defensive", "table_theta_o", "table_phi_o"}) REQUIRE(H5Ldelete(g.group, name, H5P_DEFAULT) >= 0);
    fixed_length_attr(g.group, "domain", "hemisphere");
    fixed_length_attr(g.group, "symmetry", "azimuthal");
  }
  const mix::MixtureSet ours = mix::load_mixture_h5(path);
  CHECK(ours.azimuthal);
  CHECK(ours.grid_theta_o.size() == 3);  // the slices' own directions
  CHECK(ours.slices[0].defensive == 0.1);
  check_same(ours, to_mixture_set(read_mixture_file(path)), 3);
}

TEST_CASE("the header loader's errors name the file, the object and what is wrong", "[io]") {
  CHECK(load_error(temp_path("absent.h5")).find("absent.h5: cannot open") != std::string::npos);
  const std::string text = temp_path("text.h5");
  std::ofstream(text) << "not hdf5\n";
  CHECK(load_error(text).find("not an HDF5 file") != std::string::npos);

  const std::string good = written("good.h5");
  CHECK(load_error(good).empty());
  {  // truncated: the first half of its bytes
    std::ifstream in(good, std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    std::ofstream(temp_path("truncated.h5"), std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  }
  const std::string truncated = load_error(temp_path("truncated.h5"));
  CHECK(truncated.find("truncated.h5") != std::string::npos);
  CHECK(truncated.find("corrupt") != std::string::npos);

  auto edited = [&](const std::string& name, auto&& edit) {
    const std::string path = written(name);
    {
      Group g(path);
      edit(g.group);
    }
    return load_error(path);
  };
  const std::string newer = edited("newer.h5", [](hid_t g) {
    H5Adelete(g, "format_version");
    fixed_length_attr(g, "format_version", "3");
  });
  CHECK(newer.find("newer.h5: /mixture attribute 'format_version': '3' is newer") != std::string::npos);
  // An attribute that exists but is no string is an error, never a default.
  const std::string sym = edited("symmetry_int.h5", [](hid_t g) {
    H5Adelete(g, "symmetry");
    const int one = 1;
    const hid_t space = H5Screate(H5S_SCALAR);
    const hid_t a = H5Acreate2(g, "symmetry", H5T_NATIVE_INT, space, H5P_DEFAULT, H5P_DEFAULT);
    H5Awrite(a, H5T_NATIVE_INT, &one);
    H5Aclose(a);
    H5Sclose(space);
  });
  CHECK(sym.find("symmetry_int.h5: /mixture attribute 'symmetry': is not a string") != std::string::npos);
  const std::string missing = edited("no_symmetry.h5", [](hid_t g) { H5Adelete(g, "symmetry"); });
  CHECK(missing.find("missing attribute 'symmetry'") != std::string::npos);
  const std::string shape = edited("means_shape.h5", [](hid_t g) {
    H5Ldelete(g, "means", H5P_DEFAULT);
    const hsize_t dims[2] = {3, 2};
    const float zero[6] = {0, 0, 0, 0, 0, 0};
    const hid_t space = H5Screate_simple(2, dims, nullptr);
    const hid_t d = H5Dcreate2(g, "means", H5T_NATIVE_FLOAT, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    H5Dwrite(d, H5T_NATIVE_FLOAT, H5S_ALL, H5S_ALL, H5P_DEFAULT, zero);
    H5Dclose(d);
    H5Sclose(space);
  });
  CHECK(shape.find("means_shape.h5: /mixture/means: shape [3, 2], expected") != std::string::npos);
  const std::string map = edited("fiber_map.h5", [](hid_t g) {
    H5Adelete(g, "map");
    fixed_length_attr(g, "map", "cylinder");
  });
  CHECK(map.find("map 'cylinder' does not fit the hemisphere domain") != std::string::npos);
  // bsdfmix's reader refuses each of these too.
  for (const char* name : {"truncated.h5", "newer.h5", "symmetry_int.h5", "no_symmetry.h5", "means_shape.h5", "fiber_map.h5"})
    CHECK_THROWS(read_mixture_file(temp_path(name)));
  // Every message is one line.
  for (const std::string& e : {truncated, newer, sym, missing, shape, map}) CHECK(e.find('\n') == std::string::npos);
}
