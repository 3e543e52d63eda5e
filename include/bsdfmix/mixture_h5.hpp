// bsdfmix/mixture_h5.hpp: read a bsdfmix mixture file into a ready MixtureSet.
//
//   #include <bsdfmix/mixture_h5.hpp>   // needs bsdfmix/mixture.hpp beside it and the HDF5 C library
//   bsdfmix::mix::MixtureSet set = bsdfmix::mix::load_mixture_h5("mixture.h5");
//   double rgb[3];
//   set.eval_rgb(theta_o, phi_o, theta_i, phi_i, rgb);
//
// Header-only over the HDF5 C API (1.10 or later; link hdf5). It reads every file that
// bsdfmix writes (docs/formats.md, "Mixture file"): format versions 1 (no
// `format_version`) and 2; padded and ragged storage, rgb_scale in float64 or float32; the
// colour copies (rgb_copies, 12 amplitudes per component, given to
// SliceMixture::set_copies); the `map`, `interpolation` and `symmetry` attributes; the
// Lambertian base; each slice's `defensive` share (0.1 where absent); and the table's
// omega_o axes (the slices' own directions where absent). It checks what bsdfmix's own
// reader checks and returns the set prepared. String attributes may be variable or fixed
// length, ASCII or UTF-8.
//
// Errors: std::runtime_error with one line naming the file, the dataset or attribute and
// what is wrong (a missing file, a truncated or corrupt one, a newer format_version, a
// shape that disagrees, an attribute that exists but cannot be read). HDF5's own error
// printing is off during the call and restored after it.
#pragma once

#include <bsdfmix/mixture.hpp>
#include <hdf5.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <vector>

namespace bsdfmix {
namespace mix {

// The newest mixture file format this header reads (attribute `format_version`).
constexpr int kMixtureH5Version = 2;

namespace h5_detail {

// Throws the loader's one-line error.
[[noreturn]] inline void fail(const std::string& where, const std::string& what) {
  throw std::runtime_error(where + ": " + what);
}

// Owns an HDF5 id and closes it with the right H5*close.
class Id {
 public:
  explicit Id(hid_t id = -1) : id_(id) {}
  ~Id() {
    if (id_ < 0) return;
    switch (H5Iget_type(id_)) {
      case H5I_FILE: H5Fclose(id_); break;
      case H5I_GROUP: H5Gclose(id_); break;
      case H5I_DATASET: H5Dclose(id_); break;
      case H5I_DATASPACE: H5Sclose(id_); break;
      case H5I_DATATYPE: H5Tclose(id_); break;
      case H5I_ATTR: H5Aclose(id_); break;
      default: break;
    }
  }
  Id(const Id&) = delete;
  Id& operator=(const Id&) = delete;
  hid_t get() const { return id_; }
  bool ok() const { return id_ >= 0; }

 private:
  hid_t id_;
};

// Turns HDF5's automatic error printing off for its lifetime, then restores it.
class QuietErrors {
 public:
  QuietErrors() {
    saved_ = H5Eget_auto2(H5E_DEFAULT, &func_, &data_) >= 0;
    H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  }
  ~QuietErrors() {
    if (saved_) H5Eset_auto2(H5E_DEFAULT, func_, data_);
  }
  QuietErrors(const QuietErrors&) = delete;
  QuietErrors& operator=(const QuietErrors&) = delete;

 private:
  H5E_auto2_t func_ = nullptr;
  void* data_ = nullptr;
  bool saved_ = false;
};

inline bool has(hid_t g, const char* name) { return H5Lexists(g, name, H5P_DEFAULT) > 0; }
inline bool has_attr(hid_t g, const char* name) { return H5Aexists(g, name) > 0; }

inline std::string dims_text(const std::vector<hsize_t>& d) {
  std::string s = "[";
  for (std::size_t i = 0; i < d.size(); ++i) s += (i ? ", " : "") + std::to_string(d[i]);
  return s + "]";
}

// A dataset's shape; the dataset must exist.
inline std::vector<hsize_t> shape(hid_t g, const char* name, const std::string& where) {
  if (!has(g, name)) fail(where, std::string("missing dataset ") + name);
  Id d(H5Dopen2(g, name, H5P_DEFAULT));
  if (!d.ok()) fail(where + "/" + name, "cannot open the dataset (corrupt file?)");
  Id space(H5Dget_space(d.get()));
  const int rank = space.ok() ? H5Sget_simple_extent_ndims(space.get()) : -1;
  if (rank < 0) fail(where + "/" + name, "cannot read its shape (corrupt file?)");
  std::vector<hsize_t> dims(std::size_t(rank), 0);
  if (rank > 0) H5Sget_simple_extent_dims(space.get(), dims.data(), nullptr);
  return dims;
}

// True when the dataset stores 4-byte floats.
inline bool is_float32(hid_t g, const char* name) {
  Id d(H5Dopen2(g, name, H5P_DEFAULT));
  Id t(d.ok() ? H5Dget_type(d.get()) : -1);
  return t.ok() && H5Tget_class(t.get()) == H5T_FLOAT && H5Tget_size(t.get()) == 4;
}

// A whole dataset converted to T (mem: the matching native type); its type class must be
// `want` (floating point or integer). At most 2^26 elements, as bsdfmix's reader.
template <typename T>
std::vector<T> read(hid_t g, const char* name, const std::string& where, hid_t mem, H5T_class_t want) {
  const std::vector<hsize_t> dims = shape(g, name, where);
  const std::string at = where + "/" + name;
  Id d(H5Dopen2(g, name, H5P_DEFAULT));
  Id type(H5Dget_type(d.get()));
  if (!type.ok() || H5Tget_class(type.get()) != want)
    fail(at, std::string("wrong type (expected ") + (want == H5T_FLOAT ? "floating point" : "integer") + ")");
  constexpr hsize_t kMax = hsize_t(1) << 26;
  hsize_t n = 1;
  for (const hsize_t s : dims) {
    if (s != 0 && n > kMax / s) fail(at, "impossibly large (more than 2^26 elements; corrupt file?)");
    n *= s;
  }
  std::vector<T> out(static_cast<std::size_t>(n));
  if (n > 0 && H5Dread(d.get(), mem, H5S_ALL, H5S_ALL, H5P_DEFAULT, out.data()) < 0)
    fail(at, "cannot read the data (truncated or corrupt file)");
  return out;
}

inline std::vector<double> doubles(hid_t g, const char* name, const std::string& where) {
  return read<double>(g, name, where, H5T_NATIVE_DOUBLE, H5T_FLOAT);
}
inline std::vector<float> floats(hid_t g, const char* name, const std::string& where) {
  return read<float>(g, name, where, H5T_NATIVE_FLOAT, H5T_FLOAT);
}
inline std::vector<std::int32_t> ints(hid_t g, const char* name, const std::string& where) {
  return read<std::int32_t>(g, name, where, H5T_NATIVE_INT32, H5T_INTEGER);
}

// A string attribute holding one value: variable or fixed length, in the attribute's own
// character set (HDF5 1.10 converts no ASCII <-> UTF-8). It must exist and read.
inline std::string string_attr(hid_t g, const char* name, const std::string& where) {
  const std::string at = where + " attribute '" + name + "'";
  if (!has_attr(g, name)) fail(where, std::string("missing attribute '") + name + "'");
  Id a(H5Aopen(g, name, H5P_DEFAULT));
  if (!a.ok()) fail(at, "cannot open it (corrupt file?)");
  Id space(H5Aget_space(a.get()));
  const hssize_t n = space.ok() ? H5Sget_simple_extent_npoints(space.get()) : -1;
  if (n != 1) fail(at, "must hold one value (holds " + std::to_string(n) + ")");
  Id type(H5Aget_type(a.get()));
  if (!type.ok() || H5Tget_class(type.get()) != H5T_STRING) fail(at, "is not a string");
  Id mem(H5Tcopy(H5T_C_S1));
  H5Tset_cset(mem.get(), H5Tget_cset(type.get()));
  if (H5Tis_variable_str(type.get()) > 0) {
    H5Tset_size(mem.get(), H5T_VARIABLE);
    char* s = nullptr;
    if (H5Aread(a.get(), mem.get(), &s) < 0 || !s) fail(at, "cannot read the string");
    std::string out(s);
    H5free_memory(s);
    return out;
  }
  const std::size_t size = H5Tget_size(type.get());
  std::string out(size + 1, '\0');  // room for the terminator of a full fixed-length string
  H5Tset_size(mem.get(), size + 1);
  if (H5Aread(a.get(), mem.get(), &out[0]) < 0) fail(at, "cannot read the string");
  out.resize(out.find('\0') == std::string::npos ? out.size() : out.find('\0'));
  return out;
}

// A length check of a per-slice dataset.
inline void want_length(std::size_t got, std::size_t want, const std::string& at, const char* of) {
  if (got != want) fail(at, "length " + std::to_string(got) + ", expected " + std::to_string(want) + " (" + of + ")");
}

// What the file holds, in padded arrays [S, kmax, ...] as bsdfmix's MixtureFile.
struct Stored {
  std::vector<double> theta_o, phi_o, scale, defensive, base, base_rgb, table_theta_o, table_phi_o;
  std::vector<std::int32_t> k;
  std::size_t kmax = 0;
  std::vector<float> weights, means, covariances;
  std::vector<double> rgb, copies;  // [S, kmax, 3], [S, kmax, 12]; empty: none
};

// The domain, format version, map, symmetry and interpolation attributes.
inline void read_attributes(hid_t g, const std::string& where, MixtureSet& set) {
  const std::string domain = string_attr(g, "domain", where);
  if (domain != "fiber" && domain != "hemisphere")
    fail(where + " attribute 'domain'", "unknown domain '" + domain + "' (expected fiber or hemisphere)");
  set.domain = domain == "fiber" ? Domain::Fiber : Domain::Hemisphere;
  if (has_attr(g, "format_version")) {
    const std::string v = string_attr(g, "format_version", where);
    if (v != "1" && v != std::to_string(kMixtureH5Version))
      fail(where + " attribute 'format_version'", "'" + v + "' is newer than this reader (at most " +
                                                      std::to_string(kMixtureH5Version) +
                                                      "); update bsdfmix/mixture_h5.hpp");
  }
  set.map = Map::ThetaPhi;
  if (has_attr(g, "map")) {
    const std::string m = string_attr(g, "map", where);
    if (m != "theta_phi" && m != "disk" && m != "cylinder")
      fail(where + " attribute 'map'", "unknown map '" + m + "' (expected theta_phi, disk or cylinder)");
    set.map = map_from_name(m);
    if (set.map != Map::ThetaPhi && set.map != equal_area_map(set.domain))
      fail(where + " attribute 'map'", "map '" + m + "' does not fit the " + domain + " domain");
  }
  const std::string sym = string_attr(g, "symmetry", where);
  if (sym != "azimuthal" && sym != "none") fail(where + " attribute 'symmetry'", "unknown symmetry '" + sym + "'");
  set.azimuthal = sym == "azimuthal";
  string_attr(g, "table_source", where);  // bsdfmix's reader requires it too
  set.interpolation = Interpolation::Blend;
  if (has_attr(g, "interpolation")) {
    const std::string i = string_attr(g, "interpolation", where);
    if (i != "blend" && i != "displace")
      fail(where + " attribute 'interpolation'", "unknown interpolation '" + i + "' (blend or displace)");
    if (i == "displace") set.interpolation = Interpolation::Displace;
  }
}

// The per-slice datasets, `defensive` and the base.
inline void read_slices(hid_t g, const std::string& where, bool disk, Stored& m) {
  m.theta_o = doubles(g, "theta_o", where);
  m.phi_o = doubles(g, "phi_o", where);
  m.k = ints(g, "k", where);
  m.scale = doubles(g, "scale", where);
  const std::size_t S = m.theta_o.size();
  want_length(m.phi_o.size(), S, where + "/phi_o", "the length of theta_o");
  want_length(m.scale.size(), S, where + "/scale", "the length of theta_o");
  for (const char* name : {"loglik", "l1_rel"}) want_length(doubles(g, name, where).size(), S, where + "/" + name, "the length of theta_o");
  want_length(m.k.size(), S, where + "/k", "the length of theta_o");
  m.defensive.assign(S, 0.1);
  if (has(g, "defensive")) {
    m.defensive = doubles(g, "defensive", where);
    want_length(m.defensive.size(), S, where + "/defensive", "the length of theta_o");
    for (std::size_t s = 0; s < S; ++s)
      if (!(m.defensive[s] >= 0 && m.defensive[s] < 1))
        fail(where + " slice " + std::to_string(s), "defensive is not a share in [0, 1)");
  }
  m.base.assign(S, 0.0);
  m.base_rgb.assign(3 * S, 0.0);
  if (!has(g, "base")) return;
  if (!disk) fail(where + "/base", "a base needs map 'disk'");
  m.base = doubles(g, "base", where);
  want_length(m.base.size(), S, where + "/base", "the length of theta_o");
  for (std::size_t s = 0; s < S; ++s)
    if (!(m.base[s] >= 0 && m.base[s] <= 1))
      fail(where + "/base", "slice " + std::to_string(s) + " holds " + std::to_string(m.base[s]) + ", expected a share in [0, 1]");
  if (!has(g, "base_rgb")) return;
  m.base_rgb = doubles(g, "base_rgb", where);
  want_length(m.base_rgb.size(), 3 * S, where + "/base_rgb", "[S, 3]");
}

// Checks a dataset's shape.
inline void want_shape(hid_t g, const char* name, const std::vector<hsize_t>& want, const std::string& where,
                       const char* layout) {
  const std::vector<hsize_t> got = shape(g, name, where);
  if (got != want) fail(where + "/" + name, "shape " + dims_text(got) + ", expected " + dims_text(want) + " (" + layout + ")");
}

// The component arrays, padded [S, Kmax, ...] or ragged [sum k, ...] with `offset`.
inline void read_components(hid_t g, const std::string& where, Stored& m) {
  const std::size_t S = m.theta_o.size();
  const bool rgb = has(g, "rgb_scale");
  if (!has(g, "offset")) {  // padded
    const std::vector<hsize_t> w = shape(g, "weights", where);
    if (w.size() != 2 || w[0] != S) fail(where + "/weights", "shape " + dims_text(w) + ", expected [S, Kmax] with S = " + std::to_string(S));
    m.kmax = std::size_t(w[1]);
    const hsize_t K = w[1];
    want_shape(g, "means", {S, K, 2}, where, "[S, Kmax, 2]");
    want_shape(g, "covariances", {S, K, 3}, where, "[S, Kmax, 3]");
    if (rgb) want_shape(g, "rgb_scale", {S, K, 3}, where, "[S, Kmax, 3]");
    m.weights = floats(g, "weights", where);
    m.means = floats(g, "means", where);
    m.covariances = floats(g, "covariances", where);
    if (rgb) m.rgb = doubles(g, "rgb_scale", where);
    return;
  }
  const std::vector<std::int32_t> offset = ints(g, "offset", where);
  want_length(offset.size(), S, where + "/offset", "the length of theta_o");
  std::size_t N = 0;
  for (std::size_t s = 0; s < S; ++s) {
    if (m.k[s] < 1) fail(where + " slice " + std::to_string(s), "k = " + std::to_string(m.k[s]) + " below 1");
    if (offset[s] != std::int32_t(N))
      fail(where + "/offset", "slice " + std::to_string(s) + " starts at " + std::to_string(offset[s]) + ", expected " +
                                  std::to_string(N) + " (the sum of k before it)");
    N += std::size_t(m.k[s]);
    m.kmax = std::max(m.kmax, std::size_t(m.k[s]));
  }
  want_shape(g, "weights", {N}, where, "ragged: [sum k]");
  want_shape(g, "means", {N, 2}, where, "ragged: [sum k, 2]");
  want_shape(g, "covariances", {N, 3}, where, "ragged: [sum k, 3]");
  if (rgb) want_shape(g, "rgb_scale", {N, 3}, where, "ragged: [sum k, 3]");
  const std::vector<float> w = floats(g, "weights", where), mu = floats(g, "means", where),
                           cov = floats(g, "covariances", where);
  const std::vector<double> r = rgb ? doubles(g, "rgb_scale", where) : std::vector<double>{};
  const std::size_t K = m.kmax;
  m.weights.assign(S * K, 0.f);
  m.means.assign(S * K * 2, 0.f);
  m.covariances.assign(S * K * 3, 0.f);
  if (rgb) m.rgb.assign(S * K * 3, 0.0);
  for (std::size_t s = 0; s < S; ++s)
    for (std::size_t j = 0; j < std::size_t(m.k[s]); ++j) {
      const std::size_t src = std::size_t(offset[s]) + j, dst = s * K + j;
      m.weights[dst] = w[src];
      for (std::size_t d = 0; d < 2; ++d) m.means[dst * 2 + d] = mu[src * 2 + d];
      for (std::size_t d = 0; d < 3; ++d) m.covariances[dst * 3 + d] = cov[src * 3 + d];
      for (std::size_t d = 0; rgb && d < 3; ++d) m.rgb[dst * 3 + d] = r[src * 3 + d];
    }
}

// The colour copies: copies_offset [S] (-1: none) and rgb_copies [M, 4, 3].
inline void read_copies(hid_t g, const std::string& where, Stored& m) {
  const std::size_t S = m.theta_o.size(), K = m.kmax, V = std::size_t(kCopies) * 3;
  const std::vector<std::int32_t> offset = ints(g, "copies_offset", where);
  want_length(offset.size(), S, where + "/copies_offset", "the length of theta_o");
  std::size_t M = 0;
  for (std::size_t s = 0; s < S; ++s) {
    if (offset[s] < 0) continue;
    if (offset[s] != std::int32_t(M))
      fail(where + "/copies_offset", "slice " + std::to_string(s) + " starts at " + std::to_string(offset[s]) +
                                         ", expected " + std::to_string(M) + " (the sum of k of the slices with copies before it)");
    if (m.k[s] < 1 || std::size_t(m.k[s]) > K) fail(where + " slice " + std::to_string(s), "k outside [1, Kmax]");
    M += std::size_t(m.k[s]);
  }
  want_shape(g, "rgb_copies", {M, hsize_t(kCopies), 3}, where, "the components of the slices with copies, 4 copies, R, G, B");
  const std::vector<double> rows = doubles(g, "rgb_copies", where);
  m.copies.assign(S * K * V, 0.0);
  for (std::size_t s = 0; s < S; ++s)
    for (std::size_t i = 0; offset[s] >= 0 && i < std::size_t(m.k[s]) * V; ++i)
      m.copies[s * K * V + i] = rows[std::size_t(offset[s]) * V + i];
}

// The checks of bsdfmix's reader on each slice's used components.
inline void check_slice(const Stored& m, std::size_t s, const std::string& where) {
  const std::string at = where + " slice " + std::to_string(s);
  const std::size_t K = m.kmax, V = std::size_t(kCopies) * 3;
  if (m.k[s] < 1 || std::size_t(m.k[s]) > K) fail(at, "k = " + std::to_string(m.k[s]) + " outside [1, Kmax]");
  if (!std::isfinite(m.scale[s]) || m.scale[s] < 0) fail(at, "scale is not a finite non-negative number");
  double wsum = 0;
  for (std::size_t j = 0; j < std::size_t(m.k[s]); ++j) {
    const std::string c = at + " component " + std::to_string(j);
    const std::size_t r = s * K + j;
    const float w = m.weights[r];
    const float* mu = &m.means[2 * r];
    const float* cv = &m.covariances[3 * r];
    if (!std::isfinite(w) || w < 0) fail(c, "weight is not a finite non-negative number");
    if (!std::isfinite(mu[0]) || !std::isfinite(mu[1])) fail(c, "mean is not finite");
    if (!(cv[0] > 0) || !(cv[2] > 0) || !(double(cv[0]) * cv[2] - double(cv[1]) * cv[1] > 0))
      fail(c, "covariance is not positive definite");
    wsum += w;
    for (std::size_t d = 0; !m.rgb.empty() && d < 3; ++d)
      if (!std::isfinite(m.rgb[3 * r + d]) || m.rgb[3 * r + d] < 0) fail(c, "rgb_scale is not a finite non-negative number");
    for (std::size_t d = 0; !m.copies.empty() && d < V; ++d)
      if (!std::isfinite(m.copies[V * r + d]) || m.copies[V * r + d] < 0)
        fail(c, "rgb_copies is not a finite non-negative number");
  }
  if (std::abs(wsum + m.base[s] - 1.0) > 1e-3) fail(at, "weights sum to " + std::to_string(wsum) + " with the base, expected 1");
}

// Slice s as stored (not prepared), as bsdfmix's to_mixture_set builds it.
inline SliceMixture stored_slice(const Stored& m, std::size_t s, Map map) {
  const std::size_t r = s * m.kmax, V = std::size_t(kCopies) * 3, k = std::size_t(m.k[s]);
  SliceMixture sm = slice_from_arrays(k, m.weights.data() + r, m.means.data() + 2 * r, m.covariances.data() + 3 * r,
                                      m.rgb.empty() ? nullptr : m.rgb.data() + 3 * r);
  sm.theta_o = m.theta_o[s];
  sm.phi_o = m.phi_o[s];
  sm.scale = m.scale[s];
  sm.map = map;
  sm.base = m.base[s];
  for (int c = 0; sm.base > 0 && c < 3; ++c) sm.base_rgb[c] = m.base_rgb[3 * s + std::size_t(c)];
  sm.defensive = m.defensive[s];
  if (!m.copies.empty()) {  // a slice whose copies are all zero has none
    const std::vector<double> c(m.copies.begin() + long(r * V), m.copies.begin() + long((r + k) * V));
    for (const double a : c)
      if (a != 0) {
        sm.set_copies(c);
        break;
      }
  }
  return sm;
}

}  // namespace h5_detail

// Reads group /mixture of the mixture file `path` into a prepared MixtureSet (see the top
// of this header). Throws std::runtime_error naming the file and what is wrong.
inline MixtureSet load_mixture_h5(const std::string& path) {
  namespace d = h5_detail;
  const d::QuietErrors quiet;
  if (std::FILE* f = std::fopen(path.c_str(), "rb")) std::fclose(f);
  else d::fail(path, "cannot open (no such file or not readable)");
  if (H5Fis_hdf5(path.c_str()) <= 0) d::fail(path, "not an HDF5 file (corrupt, truncated or another format)");
  const d::Id file(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT));
  if (!file.ok()) d::fail(path, "cannot open as HDF5 (corrupt or truncated file)");
  if (!d::has(file.get(), "mixture")) d::fail(path, "missing group /mixture (not a bsdfmix mixture file)");
  const d::Id group(H5Gopen2(file.get(), "mixture", H5P_DEFAULT));
  if (!group.ok()) d::fail(path, "cannot open group /mixture (corrupt file?)");
  const hid_t g = group.get();
  const std::string where = path + ": /mixture";
  MixtureSet set;
  d::read_attributes(g, where, set);
  d::Stored m;
  d::read_slices(g, where, set.map == Map::Disk, m);
  d::read_components(g, where, m);
  if (!m.rgb.empty() && d::has(g, "rgb_copies")) d::read_copies(g, where, m);
  if (d::has(g, "table_theta_o")) {
    set.grid_theta_o = d::doubles(g, "table_theta_o", where);
    set.grid_phi_o = d::doubles(g, "table_phi_o", where);
  } else {  // a file without the grid: its own slices form it
    set.grid_theta_o = m.theta_o;
    set.grid_phi_o = set.azimuthal ? std::vector<double>{0.0} : m.phi_o;
  }
  for (std::size_t s = 0; s < m.theta_o.size(); ++s) {
    d::check_slice(m, s, where);
    set.slices.push_back(d::stored_slice(m, s, set.map));
  }
  try {
    set.prepare();
  } catch (const std::exception& e) {
    d::fail(where, e.what());
  }
  return set;
}

}  // namespace mix
}  // namespace bsdfmix
