// The HDF5 mixture file: write atomically, read with validation.
#include "io/mixture_file.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "io/h5.hpp"
#include "io/mixture_parts.hpp"

namespace bsdfmix {

void MixtureFile::add_slice(double theta_o_, double phi_o_, double scale_, double loglik_, double l1_rel_,
                            const std::vector<double>& w, const std::vector<double>& mean,
                            const std::vector<double>& cov, const std::vector<double>* rgb,
                            const std::vector<double>* copies) {
  const int kk = static_cast<int>(w.size());
  if (copies && copies->empty()) copies = nullptr;
  if (mean.size() != 2 * w.size() || cov.size() != 3 * w.size() || (rgb && rgb->size() != 3 * w.size()) ||
      (copies && (!rgb || copies->size() != kCopyValues * w.size())))
    throw Error("MixtureFile::add_slice: inconsistent component arrays");
  if (slices() > 0 && (rgb != nullptr) != has_rgb())
    throw Error("MixtureFile::add_slice: every slice has rgb_scale, or none");
  if (copies && !has_copies()) rgb_copies.assign(slices() * std::size_t(kmax) * kCopyValues, 0.0);
  if (kk > kmax) {  // widen every stored slice
    const std::size_t s = slices();
    std::vector<float> nw(s * kk, 0.f), nm(s * kk * 2, 0.f), nc(s * kk * 3, 0.f);
    std::vector<double> nr(has_rgb() ? s * kk * 3 : 0, 0.0), ncp(has_copies() ? s * kk * kCopyValues : 0, 0.0);
    for (std::size_t i = 0; i < s; ++i)
      for (int j = 0; j < kmax; ++j) {
        if (has_copies())
          for (std::size_t d = 0; d < kCopyValues; ++d)
            ncp[(i * kk + j) * kCopyValues + d] = rgb_copies[(i * kmax + j) * kCopyValues + d];
        nw[i * kk + j] = weights[i * kmax + j];
        for (int d = 0; d < 2; ++d) nm[(i * kk + j) * 2 + d] = means[(i * kmax + j) * 2 + d];
        for (int d = 0; d < 3; ++d) nc[(i * kk + j) * 3 + d] = covariances[(i * kmax + j) * 3 + d];
        if (has_rgb())
          for (int d = 0; d < 3; ++d) nr[(i * kk + j) * 3 + d] = rgb_scale[(i * kmax + j) * 3 + d];
      }
    weights.swap(nw);
    means.swap(nm);
    covariances.swap(nc);
    rgb_scale.swap(nr);
    rgb_copies.swap(ncp);
    kmax = kk;
  }
  theta_o.push_back(theta_o_);
  phi_o.push_back(phi_o_);
  scale.push_back(scale_);
  loglik.push_back(loglik_);
  l1_rel.push_back(l1_rel_);
  defensive.push_back(kDefaultDefensive);
  k.push_back(kk);
  base.push_back(0.0);
  base_rgb.insert(base_rgb.end(), 3, 0.0);
  for (int j = 0; j < kmax; ++j) {
    const bool used = j < kk;
    weights.push_back(used ? float(w[j]) : 0.f);
    for (int d = 0; d < 2; ++d) means.push_back(used ? float(mean[2 * j + d]) : 0.f);
    for (int d = 0; d < 3; ++d) covariances.push_back(used ? float(cov[3 * j + d]) : 0.f);
    if (rgb)
      for (int d = 0; d < 3; ++d) rgb_scale.push_back(used ? (*rgb)[3 * j + d] : 0.0);
    if (copies || has_copies())  // (the first slice with copies starts the array)
      for (std::size_t d = 0; d < kCopyValues; ++d) rgb_copies.push_back(used && copies ? (*copies)[kCopyValues * j + d] : 0.0);
  }
}

void MixtureFile::set_base(double share, const double* rgb) {
  if (base.empty()) throw Error("MixtureFile::set_base: no slice yet");
  base.back() = share;
  for (int c = 0; c < 3; ++c) base_rgb[base_rgb.size() - 3 + std::size_t(c)] = rgb ? rgb[c] : 0.0;
}

bool MixtureFile::has_base() const {
  return std::any_of(base.begin(), base.end(), [](double b) { return b > 0; });
}

void MixtureFile::slice_params(std::size_t s, std::vector<double>& w, std::vector<double>& mean,
                               std::vector<double>& cov) const {
  const std::size_t K = static_cast<std::size_t>(kmax);
  const int kk = k[s];
  w.assign(kk, 0.0);
  mean.assign(2 * kk, 0.0);
  cov.assign(3 * kk, 0.0);
  for (int j = 0; j < kk; ++j) {
    w[j] = weights[s * K + j];
    for (int d = 0; d < 2; ++d) mean[2 * j + d] = means[(s * K + j) * 2 + d];
    for (int d = 0; d < 3; ++d) cov[3 * j + d] = covariances[(s * K + j) * 3 + d];
  }
}

std::vector<double> MixtureFile::slice_rgb(std::size_t s) const {
  if (!has_rgb()) return {};
  const std::size_t K = static_cast<std::size_t>(kmax);
  return std::vector<double>(rgb_scale.begin() + long(s * K * 3), rgb_scale.begin() + long((s * K + k[s]) * 3));
}

std::vector<double> MixtureFile::slice_copies(std::size_t s) const {
  if (!has_copies()) return {};
  const std::size_t K = static_cast<std::size_t>(kmax);
  std::vector<double> c(rgb_copies.begin() + long(s * K * kCopyValues),
                        rgb_copies.begin() + long((s * K + k[s]) * kCopyValues));
  return std::any_of(c.begin(), c.end(), [](double x) { return x != 0; }) ? c : std::vector<double>{};
}

void MixtureFile::add_slice_from(const MixtureFile& from, std::size_t s) {
  std::vector<double> w, mean, cov;
  from.slice_params(s, w, mean, cov);
  const std::vector<double> rgb = from.slice_rgb(s), copies = from.slice_copies(s);
  add_slice(from.theta_o[s], from.phi_o[s], from.scale[s], from.loglik[s], from.l1_rel[s], w, mean, cov,
            from.has_rgb() ? &rgb : nullptr, &copies);
  set_base(from.base[s], &from.base_rgb[3 * s]);
  defensive.back() = from.defensive[s];
}

MixtureFile MixtureFile::header_only() const {
  MixtureFile h;
  h.storage = storage;
  h.domain = domain;
  h.map = map;
  h.azimuthal = azimuthal;
  h.table_source = table_source;
  h.fit_settings = fit_settings;
  h.interpolation = interpolation;
  h.table_theta_o = table_theta_o;
  h.table_phi_o = table_phi_o;
  return h;
}

std::string storage_name(const MixtureStorage& s) {
  return std::string(s.ragged ? "ragged" : "padded") + (s.float32 ? "_f32" : "");
}

MixtureStorage parse_storage(const std::string& name, const std::string& where) {
  for (const bool r : {false, true})
    for (const bool f : {false, true})
      if (storage_name({r, f}) == name) return {r, f};
  throw InputError(where + ": unknown storage '" + name + "' (padded, ragged, padded_f32 or ragged_f32)");
}

std::uint64_t MixtureFile::stored_components() const {
  if (!storage.ragged) return std::uint64_t(slices()) * std::uint64_t(std::max(kmax, 0));
  std::uint64_t n = 0;
  for (const auto kk : k) n += std::uint64_t(kk);
  return n;
}

std::uint64_t MixtureFile::payload_bytes() const {
  // Exactly what write_mixture_group stores: the float component arrays (padded [S, kmax]
  // or ragged [sum k]) and rgb_scale (float64 or float32), the per-slice doubles, int32 k
  // (and, ragged, int32 offset), and the table's omega_o axes.
  const std::uint64_t S = slices(), N = stored_components();
  const std::uint64_t rgb_bytes = storage.float32 ? sizeof(float) : sizeof(double);
  std::uint64_t copied = 0;  // the components of the slices with colour copies: rgb_copies' rows
  for (std::size_t i = 0; has_copies() && i < S; ++i)
    if (!slice_copies(i).empty()) copied += std::uint64_t(k[i]);
  return N * 6 * sizeof(float) + (has_rgb() ? N * 3 * rgb_bytes : 0) +
         (has_copies() ? copied * kCopyValues * rgb_bytes + S * sizeof(std::int32_t) : 0) + S * 6 * sizeof(double) +
         S * sizeof(std::int32_t) * (storage.ragged ? 2 : 1) +
         (table_theta_o.size() + table_phi_o.size()) * sizeof(double);
}

namespace {

// A colour amplitude dataset (rgb_scale, rgb_copies) in float64 or float32.
void write_amplitudes(hid_t id, const char* name, const std::vector<hsize_t>& dims, const std::vector<double>& v,
                      bool float32, const std::string& path) {
  if (!float32) return h5::write_doubles(id, name, dims, v.data(), path);
  const std::vector<float> f(v.begin(), v.end());
  h5::write_floats(id, name, dims, f.data(), path);
}

}  // namespace

void write_mixture_group(hid_t file, const MixtureFile& m, const std::string& path) {
  const std::size_t s = m.slices();
  h5::Handle g = h5::create_group(file, "mixture", path);
  const hid_t id = g.get();
  const hsize_t S = s, K = static_cast<hsize_t>(m.kmax);
  h5::write_doubles(id, "theta_o", {S}, m.theta_o.data(), path);
  h5::write_doubles(id, "phi_o", {S}, m.phi_o.data(), path);
  h5::write_ints(id, "k", {S}, m.k.data(), path);
  if (m.storage.ragged) {  // one flat [sum k, ...] array per quantity, slice s at offset[s]
    std::vector<std::int32_t> offset;
    std::vector<float> w, mu, cov;
    std::vector<double> rgbd;
    for (std::size_t i = 0; i < s; ++i) {
      offset.push_back(static_cast<std::int32_t>(w.size()));
      for (int j = 0; j < m.k[i]; ++j) {
        const std::size_t c = i * K + std::size_t(j);
        w.push_back(m.weights[c]);
        for (int d = 0; d < 2; ++d) mu.push_back(m.means[c * 2 + d]);
        for (int d = 0; d < 3; ++d) cov.push_back(m.covariances[c * 3 + d]);
        if (m.has_rgb())
          for (int d = 0; d < 3; ++d) rgbd.push_back(m.rgb_scale[c * 3 + d]);
      }
    }
    const hsize_t N = w.size();
    h5::write_ints(id, "offset", {S}, offset.data(), path);
    h5::write_floats(id, "weights", {N}, w.data(), path);
    h5::write_floats(id, "means", {N, 2}, mu.data(), path);
    h5::write_floats(id, "covariances", {N, 3}, cov.data(), path);
    if (m.has_rgb()) write_amplitudes(id, "rgb_scale", {N, 3}, rgbd, m.storage.float32, path);
  } else {
    h5::write_floats(id, "weights", {S, K}, m.weights.data(), path);
    h5::write_floats(id, "means", {S, K, 2}, m.means.data(), path);
    h5::write_floats(id, "covariances", {S, K, 3}, m.covariances.data(), path);
    if (m.has_rgb()) write_amplitudes(id, "rgb_scale", {S, K, 3}, m.rgb_scale, m.storage.float32, path);
  }
  if (m.has_copies()) {  // the slices with colour copies alone, in either storage
    std::vector<std::int32_t> offset;
    std::vector<double> rows;
    for (std::size_t i = 0; i < s; ++i) {
      const std::vector<double> c = m.slice_copies(i);
      offset.push_back(c.empty() ? -1 : static_cast<std::int32_t>(rows.size() / kCopyValues));
      rows.insert(rows.end(), c.begin(), c.end());
    }
    h5::write_ints(id, "copies_offset", {S}, offset.data(), path);
    write_amplitudes(id, "rgb_copies", {rows.size() / kCopyValues, 4, 3}, rows, m.storage.float32, path);
  }
  h5::write_doubles(id, "scale", {S}, m.scale.data(), path);
  h5::write_doubles(id, "loglik", {S}, m.loglik.data(), path);
  h5::write_doubles(id, "l1_rel", {S}, m.l1_rel.data(), path);
  if (m.has_base()) {
    h5::write_doubles(id, "base", {S}, m.base.data(), path);
    if (m.has_rgb()) h5::write_doubles(id, "base_rgb", {S, 3}, m.base_rgb.data(), path);
  }
  h5::write_doubles(id, "defensive", {S}, m.defensive.data(), path);
  h5::write_doubles(id, "table_theta_o", {m.table_theta_o.size()}, m.table_theta_o.data(), path);
  h5::write_doubles(id, "table_phi_o", {m.table_phi_o.size()}, m.table_phi_o.data(), path);
  h5::write_string_attr(id, "domain", domain_name(m.domain), path);
  h5::write_string_attr(id, "map", map_name(m.map), path);
  h5::write_string_attr(id, "format_version", std::to_string(kMixtureFormatVersion), path);
  h5::write_string_attr(id, "symmetry", m.azimuthal ? "azimuthal" : "none", path);
  h5::write_string_attr(id, "table_source", m.table_source, path);
  h5::write_string_attr(id, "fit_settings", m.fit_settings, path);
  if (m.interpolation != mix::Interpolation::Blend)
    h5::write_string_attr(id, "interpolation", interpolation_name(m.interpolation), path);
}

const char* interpolation_name(mix::Interpolation i) {
  return i == mix::Interpolation::Displace ? "displace" : "blend";
}

mix::Interpolation parse_interpolation(const std::string& name, const std::string& where) {
  if (name == "blend") return mix::Interpolation::Blend;
  if (name == "displace") return mix::Interpolation::Displace;
  throw InputError(where + ": unknown interpolation '" + name + "' (blend or displace)");
}

void write_mixture_file(const std::string& path, const MixtureFile& m) {
  AtomicOutput out(path);
  {
    h5::Handle f = h5::create_file(out.temp_path());
    write_mixture_group(f.get(), m, path);
    if (H5Fflush(f.get(), H5F_SCOPE_GLOBAL) < 0) throw IoError(path + ": flush failed (disk full?)");
  }
  out.commit();
}

namespace {

std::string dims_text(const std::vector<hsize_t>& dims) {
  std::string got;
  for (std::size_t i = 0; i < dims.size(); ++i) got += (i ? ", " : "") + std::to_string(dims[i]);
  return got;
}

bool is_float32(hid_t dataset) {
  h5::Handle t(H5Dget_type(dataset));
  return H5Tget_class(t.get()) == H5T_FLOAT && H5Tget_size(t.get()) == 4;
}

// The ragged layout: offset [S], weights [N], means [N, 2], covariances [N, 3], rgb_scale
// [N, 3], slice s at offset[s] .. offset[s] + k[s]; spread into the padded arrays of memory.
void read_ragged(hid_t id, const std::string& where, MixtureFile& m) {
  const std::size_t S = m.slices();
  m.storage.ragged = true;
  const std::vector<std::int32_t> offset = h5::read_ints(id, "offset", where);
  if (offset.size() != S)
    throw InputError(where + "/offset: length " + std::to_string(offset.size()) + ", expected " + std::to_string(S));
  std::size_t N = 0;
  m.kmax = 0;
  for (std::size_t s = 0; s < S; ++s) {
    if (m.k[s] < 1) throw InputError(where + " slice " + std::to_string(s) + ": k = " + std::to_string(m.k[s]) + " below 1");
    if (offset[s] != std::int32_t(N))
      throw InputError(where + "/offset: slice " + std::to_string(s) + " starts at " + std::to_string(offset[s]) +
                       ", expected " + std::to_string(N) + " (the sum of k before it)");
    N += std::size_t(m.k[s]);
    m.kmax = std::max(m.kmax, int(m.k[s]));
  }
  const bool rgb = h5::exists(id, "rgb_scale");
  for (const auto& [name, last] : {std::pair{"weights", 0}, std::pair{"means", 2}, std::pair{"covariances", 3},
                                   std::pair{"rgb_scale", 3}}) {
    if (std::string(name) == "rgb_scale" && !rgb) continue;
    h5::Handle d = h5::open_dataset(id, name, where);
    const std::vector<hsize_t> dims = h5::shape(d.get());
    const std::vector<hsize_t> want = last ? std::vector<hsize_t>{N, hsize_t(last)} : std::vector<hsize_t>{N};
    if (dims != want)
      throw InputError(where + "/" + name + ": shape [" + dims_text(dims) + "], expected [" + dims_text(want) +
                       "] (ragged: [sum k" + (last ? ", " + std::to_string(last) : std::string()) + "])");
    if (std::string(name) == "rgb_scale") m.storage.float32 = is_float32(d.get());
  }
  const std::vector<float> w = h5::read_floats(id, "weights", where), mu = h5::read_floats(id, "means", where),
                           cov = h5::read_floats(id, "covariances", where);
  const std::vector<double> r = rgb ? h5::read_doubles(id, "rgb_scale", where) : std::vector<double>{};
  const std::size_t K = std::size_t(m.kmax);
  m.weights.assign(S * K, 0.f);
  m.means.assign(S * K * 2, 0.f);
  m.covariances.assign(S * K * 3, 0.f);
  if (rgb) m.rgb_scale.assign(S * K * 3, 0.0);
  for (std::size_t s = 0; s < S; ++s)
    for (int j = 0; j < m.k[s]; ++j) {
      const std::size_t src = std::size_t(offset[s]) + std::size_t(j), dst = s * K + std::size_t(j);
      m.weights[dst] = w[src];
      for (int d = 0; d < 2; ++d) m.means[dst * 2 + d] = mu[src * 2 + d];
      for (int d = 0; d < 3; ++d) m.covariances[dst * 3 + d] = cov[src * 3 + d];
      if (rgb)
        for (int d = 0; d < 3; ++d) m.rgb_scale[dst * 3 + d] = r[src * 3 + d];
    }
}

// The colour copies: copies_offset [S] (-1: none) and rgb_copies [M, 4, 3], the rows of
// the slices with copies in order, k[s] rows each; spread into the padded array of memory.
void read_copies(hid_t id, const std::string& where, MixtureFile& m) {
  const std::size_t S = m.slices(), K = std::size_t(m.kmax);
  const std::vector<std::int32_t> offset = h5::read_ints(id, "copies_offset", where);
  if (offset.size() != S)
    throw InputError(where + "/copies_offset: length " + std::to_string(offset.size()) + ", expected " + std::to_string(S));
  std::size_t M = 0;
  for (std::size_t s = 0; s < S; ++s) {
    if (offset[s] < 0) continue;
    if (offset[s] != std::int32_t(M))
      throw InputError(where + "/copies_offset: slice " + std::to_string(s) + " starts at " + std::to_string(offset[s]) +
                       ", expected " + std::to_string(M) + " (the sum of k of the slices with copies before it)");
    M += std::size_t(m.k[s]);
  }
  h5::Handle d = h5::open_dataset(id, "rgb_copies", where);
  const std::vector<hsize_t> dims = h5::shape(d.get()), want = {M, 4, 3};
  if (dims != want)
    throw InputError(where + "/rgb_copies: shape [" + dims_text(dims) + "], expected [" + dims_text(want) +
                     "] (the components of the slices with copies, 4 copies, R, G, B)");
  const std::vector<double> rows = h5::read_doubles(id, "rgb_copies", where);
  m.rgb_copies.assign(S * K * kCopyValues, 0.0);
  for (std::size_t s = 0; s < S; ++s)
    if (offset[s] >= 0)
      std::copy(rows.begin() + long(std::size_t(offset[s]) * kCopyValues),
                rows.begin() + long((std::size_t(offset[s]) + std::size_t(m.k[s])) * kCopyValues),
                m.rgb_copies.begin() + long(s * K * kCopyValues));
}

}  // namespace

MixtureFile read_mixture_file(const std::string& path) {
  h5::Handle f = h5::open_file(path);
  h5::Handle g = h5::open_group(f.get(), "mixture", path);
  const std::string where = path + ": /mixture";
  const hid_t id = g.get();
  MixtureFile m;
  read_mixture_plane(id, where, m);
  const std::string sym = h5::read_string_attr(id, "symmetry", where);
  if (sym != "azimuthal" && sym != "none") throw InputError(where + ": unknown symmetry '" + sym + "'");
  m.azimuthal = sym == "azimuthal";
  m.table_source = h5::read_string_attr(id, "table_source", where);
  if (h5::has_attr(id, "fit_settings")) m.fit_settings = h5::read_string_attr(id, "fit_settings", where);
  if (h5::has_attr(id, "interpolation"))
    m.interpolation = parse_interpolation(h5::read_string_attr(id, "interpolation", where), where + " attribute");
  m.theta_o = h5::read_doubles(id, "theta_o", where);
  m.phi_o = h5::read_doubles(id, "phi_o", where);
  m.k = h5::read_ints(id, "k", where);
  m.scale = h5::read_doubles(id, "scale", where);
  m.loglik = h5::read_doubles(id, "loglik", where);
  m.l1_rel = h5::read_doubles(id, "l1_rel", where);
  const std::size_t S = m.theta_o.size();
  for (const auto& [name, v] : {std::pair{"phi_o", &m.phi_o}, std::pair{"scale", &m.scale},
                                 std::pair{"loglik", &m.loglik}, std::pair{"l1_rel", &m.l1_rel}})
    if (v->size() != S)
      throw InputError(where + "/" + name + ": length " + std::to_string(v->size()) + ", expected " +
                       std::to_string(S) + " (the length of theta_o)");
  if (m.k.size() != S) throw InputError(where + "/k: length " + std::to_string(m.k.size()) + ", expected " + std::to_string(S));
  read_mixture_base(id, where, m);
  if (h5::exists(id, "offset")) {
    read_ragged(id, where, m);
  } else {
    {
      h5::Handle d = h5::open_dataset(id, "weights", where);
      const auto dims = h5::shape(d.get());
      if (dims.size() != 2 || dims[0] != S) throw InputError(where + "/weights: expected shape [S, Kmax] with S = " + std::to_string(S));
      m.kmax = static_cast<int>(dims[1]);
    }
    // The full shapes, not only the element counts: [S, 2, Kmax] has as many elements as
    // [S, Kmax, 2] and would be read in the wrong order.
    for (const auto& [name, last] : {std::pair{"means", 2}, std::pair{"covariances", 3}}) {
      h5::Handle d = h5::open_dataset(id, name, where);
      const std::vector<hsize_t> dims = h5::shape(d.get()), want = {S, hsize_t(m.kmax), hsize_t(last)};
      if (dims != want)
        throw InputError(where + "/" + name + ": shape [" + dims_text(dims) + "], expected [S, Kmax, " + std::to_string(last) +
                         "] = [" + std::to_string(S) + ", " + std::to_string(m.kmax) + ", " + std::to_string(last) + "]");
    }
    m.weights = h5::read_floats(id, "weights", where);
    m.means = h5::read_floats(id, "means", where);
    m.covariances = h5::read_floats(id, "covariances", where);
    if (h5::exists(id, "rgb_scale")) {  // optional: files written before colour have none
      h5::Handle d = h5::open_dataset(id, "rgb_scale", where);
      if (h5::shape(d.get()) != std::vector<hsize_t>{S, hsize_t(m.kmax), 3})
        throw InputError(where + "/rgb_scale: expected shape [S, Kmax, 3] = [" + std::to_string(S) + ", " +
                         std::to_string(m.kmax) + ", 3]");
      m.storage.float32 = is_float32(d.get());
      m.rgb_scale = h5::read_doubles(id, "rgb_scale", where);
    }
  }
  if (m.has_rgb() && h5::exists(id, "rgb_copies")) read_copies(id, where, m);  // optional, in either storage
  const std::size_t K = static_cast<std::size_t>(m.kmax);
  if (h5::exists(id, "table_theta_o")) {
    m.table_theta_o = h5::read_doubles(id, "table_theta_o", where);
    m.table_phi_o = h5::read_doubles(id, "table_phi_o", where);
  } else {  // a file without the grid: its own slices form the grid
    m.table_theta_o = m.theta_o;
    m.table_phi_o = m.azimuthal ? std::vector<double>{0.0} : m.phi_o;
  }
  for (std::size_t s = 0; s < S; ++s) {
    const std::string at = where + " slice " + std::to_string(s);
    if (m.k[s] < 1 || m.k[s] > m.kmax) throw InputError(at + ": k = " + std::to_string(m.k[s]) + " outside [1, Kmax]");
    if (!std::isfinite(m.scale[s]) || m.scale[s] < 0) throw InputError(at + ": scale is not a finite non-negative number");
    double wsum = 0;
    for (int j = 0; j < m.k[s]; ++j) {
      const float w = m.weights[s * K + j];
      const float* c = &m.covariances[(s * K + j) * 3];
      const float* mu = &m.means[(s * K + j) * 2];
      if (!std::isfinite(w) || w < 0) throw InputError(at + " component " + std::to_string(j) + ": weight is not a finite non-negative number");
      if (!std::isfinite(mu[0]) || !std::isfinite(mu[1])) throw InputError(at + " component " + std::to_string(j) + ": mean is not finite");
      if (!(c[0] > 0) || !(c[2] > 0) || !(double(c[0]) * c[2] - double(c[1]) * c[1] > 0))
        throw InputError(at + " component " + std::to_string(j) + ": covariance is not positive definite");
      wsum += w;
      if (m.has_rgb())
        for (int ch = 0; ch < 3; ++ch) {
          const double a = m.rgb_scale[(s * K + j) * 3 + ch];
          if (!std::isfinite(a) || a < 0)
            throw InputError(at + " component " + std::to_string(j) + ": rgb_scale is not a finite non-negative number");
        }
      if (m.has_copies())
        for (std::size_t d = 0; d < kCopyValues; ++d) {
          const double a = m.rgb_copies[(s * K + j) * kCopyValues + d];
          if (!std::isfinite(a) || a < 0)
            throw InputError(at + " component " + std::to_string(j) + ": rgb_copies is not a finite non-negative number");
        }
    }
    if (std::abs(wsum + m.base[s] - 1.0) > 1e-3)
      throw InputError(at + ": weights sum to " + std::to_string(wsum) + (m.base[s] > 0 ? " beside a base of " + std::to_string(m.base[s]) : std::string()) + ", expected 1");
  }
  return m;
}

namespace {

// Slice s as stored, not yet prepared.
mix::SliceMixture stored_slice(const MixtureFile& m, std::size_t s) {
  const std::size_t r = s * static_cast<std::size_t>(m.kmax);  // the slice's first row
  mix::SliceMixture sm = mix::slice_from_arrays(std::size_t(m.k[s]), m.weights.data() + r, m.means.data() + 2 * r,
                                                m.covariances.data() + 3 * r,
                                                m.has_rgb() ? m.rgb_scale.data() + 3 * r : nullptr);
  sm.theta_o = m.theta_o[s];
  sm.phi_o = m.phi_o[s];
  sm.scale = m.scale[s];
  sm.map = m.map;
  sm.base = m.base.empty() ? 0.0 : m.base[s];
  for (int c = 0; sm.base > 0 && c < 3; ++c) sm.base_rgb[c] = m.base_rgb[3 * s + std::size_t(c)];
  sm.defensive = m.defensive[s];
  const std::vector<double> copies = m.slice_copies(s);
  if (!copies.empty()) sm.set_copies(copies);
  return sm;
}

}  // namespace

mix::SliceMixture slice_mixture(const MixtureFile& m, std::size_t s) {
  mix::SliceMixture sm = stored_slice(m, s);
  sm.map = m.map;
  sm.prepare();
  return sm;
}

mix::MixtureSet to_mixture_set(const MixtureFile& m) {
  mix::MixtureSet set;
  set.domain = m.domain;
  set.map = m.map;
  set.azimuthal = m.azimuthal;
  set.grid_theta_o = m.table_theta_o;
  set.grid_phi_o = m.table_phi_o;
  for (std::size_t s = 0; s < m.slices(); ++s) set.slices.push_back(stored_slice(m, s));
  set.interpolation = m.interpolation;
  set.prepare();
  return set;
}

}  // namespace bsdfmix
