// BatchPart <-> bytes: a versioned header, then every field in a fixed order (part_fields,
// one list for both directions), each vector as its length followed by its raw elements,
// each list of report or search rows as its length followed by every row's fields
// (sweep/row_fields.hpp; strings: length, then bytes).
#include "scale/part_codec.hpp"

#include <algorithm>
#include <cstring>
#include <type_traits>

#include "core/error.hpp"
#include "sweep/row_fields.hpp"

namespace bsdfmix::scale {

namespace {

constexpr std::uint32_t kMagic = 0x42504D58;  // "XMPB"
// 2: the report and search rows as fields, not CSV text; 3: rgb_scale and the rows' RGB errors;
// 4: rgb_copies; 5: the map, the base and its colour, the earned share
constexpr std::uint32_t kVersion = 5;

// Calls visit(field) for every field of a row, as row_fields.hpp lists them.
struct ReportFields {
  template <class Row, class Visit>
  void operator()(Row& r, Visit&& visit) const {
    report_fields(r, [&](const char*, auto& v, CsvText) { visit(v); });
  }
};
struct SearchFields {
  template <class Row, class Visit>
  void operator()(Row& r, Visit&& visit) const {
    search_fields(r, [&](const char*, auto& v, CsvText) { visit(v); });
  }
};

// The bytes a field of a row takes at the least (a string: its length alone).
template <class T>
constexpr std::size_t least_bytes() {
  if constexpr (std::is_same_v<T, std::string> || std::is_same_v<T, std::size_t>) return 8;
  else if constexpr (std::is_same_v<T, int>) return 4;
  else if constexpr (std::is_same_v<T, bool>) return 1;
  else return sizeof(T);
}

// The fewest bytes a row takes.
template <class Row, class Fields>
std::size_t least_row_bytes(Fields fields) {
  std::size_t n = 0;
  const Row row{};
  fields(row, [&](const auto& v) { n += least_bytes<std::decay_t<decltype(v)>>(); });
  return n;
}

class Writer {
 public:
  template <class T>
  void pod(const T& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    const auto* p = reinterpret_cast<const std::uint8_t*>(&v);
    out.insert(out.end(), p, p + sizeof(T));
  }
  // One field: std::size_t as uint64, int as int32, bool as uint8, a Domain as int32,
  // other numbers as they are; strings and vectors as their length, then their contents.
  template <class T>
  void field(const T& v) {
    if constexpr (std::is_same_v<T, std::size_t>) pod(std::uint64_t(v));
    else if constexpr (std::is_same_v<T, int> || std::is_enum_v<T>) pod(std::int32_t(v));
    else if constexpr (std::is_same_v<T, bool>) pod(std::uint8_t(v));
    else pod(v);
  }
  void field(const std::string& s) {
    pod(std::uint64_t(s.size()));
    out.insert(out.end(), s.begin(), s.end());
  }
  template <class T>
  void field(const std::vector<T>& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    pod(std::uint64_t(v.size()));
    if constexpr (std::is_same_v<T, std::size_t>) {
      for (std::size_t x : v) pod(std::uint64_t(x));
    } else {
      const auto* p = reinterpret_cast<const std::uint8_t*>(v.data());
      out.insert(out.end(), p, p + v.size() * sizeof(T));
    }
  }
  template <class Row, class Fields>
  void rows(const std::vector<Row>& rows, Fields fields) {
    pod(std::uint64_t(rows.size()));
    for (const Row& r : rows) fields(r, [&](const auto& v) { field(v); });
  }
  std::vector<std::uint8_t> out;
};

class Reader {
 public:
  Reader(const std::uint8_t* d, std::size_t n) : data_(d), size_(n) {}
  template <class T>
  T pod() {
    T v;
    take(&v, sizeof(T));
    return v;
  }
  // One field, as Writer::field wrote it.
  template <class T>
  void field(T& v) {
    if constexpr (std::is_same_v<T, std::size_t>) v = std::size_t(pod<std::uint64_t>());
    else if constexpr (std::is_same_v<T, int> || std::is_enum_v<T>) v = static_cast<T>(pod<std::int32_t>());
    else if constexpr (std::is_same_v<T, bool>) {
      const std::uint8_t b = pod<std::uint8_t>();
      if (b > 1) fail();
      v = b != 0;
    } else v = pod<T>();
  }
  void field(std::string& s) {
    const std::uint64_t n = pod<std::uint64_t>();
    if (n > size_ - at_) fail();
    s.assign(reinterpret_cast<const char*>(data_ + at_), n);
    at_ += n;
  }
  template <class T>
  void field(std::vector<T>& v) {
    const std::uint64_t n = pod<std::uint64_t>();
    if (n > (size_ - at_) / sizeof(T)) fail();
    v.resize(n);
    if constexpr (std::is_same_v<T, std::size_t>) {
      for (std::size_t& x : v) x = std::size_t(pod<std::uint64_t>());
    } else {
      take(v.data(), n * sizeof(T));
    }
  }
  template <class Row, class Fields>
  void rows(std::vector<Row>& rows, Fields fields) {
    // Refused when the bytes left cannot hold the count of rows.
    const std::uint64_t n = pod<std::uint64_t>();
    if (n > (size_ - at_) / least_row_bytes<Row>(fields)) fail();
    rows.resize(n);
    for (Row& r : rows) fields(r, [&](auto& v) { field(v); });
  }
  bool done() const { return at_ == size_; }
  [[noreturn]] static void fail() { throw InputError("batch part message: truncated or malformed"); }

 private:
  void take(void* dst, std::size_t n) {
    if (n > size_ - at_) fail();
    if (n) std::memcpy(dst, data_ + at_, n);
    at_ += n;
  }
  const std::uint8_t* data_;
  std::size_t size_, at_ = 0;
};

// Every field of a part, in wire order: a Writer reads them, a Reader sets them.
template <class Part, class Io>
void part_fields(Part& p, Io& io) {
  auto& m = p.mixture;
  io.field(p.slice_index);
  io.field(m.domain);
  io.field(m.map);
  io.field(m.azimuthal);
  io.field(m.table_source);
  io.field(m.fit_settings);
  for (auto* v : {&m.table_theta_o, &m.table_phi_o, &m.theta_o, &m.phi_o, &m.scale, &m.loglik, &m.l1_rel, &m.defensive}) io.field(*v);
  io.field(m.k);
  io.field(m.kmax);
  for (auto* v : {&m.weights, &m.means, &m.covariances}) io.field(*v);
  io.field(m.rgb_scale);
  io.field(m.rgb_copies);
  io.field(m.base);
  io.field(m.base_rgb);
  io.rows(p.report, ReportFields{});
  io.rows(p.search, SearchFields{});
  io.field(p.slices_hash);
}

}  // namespace

std::vector<std::uint8_t> encode_part(const BatchPart& p) {
  Writer w;
  w.pod(kMagic);
  w.pod(kVersion);
  part_fields(p, w);
  return std::move(w.out);
}

BatchPart decode_part(const std::uint8_t* data, std::size_t size) {
  Reader r(data, size);
  if (r.pod<std::uint32_t>() != kMagic || r.pod<std::uint32_t>() != kVersion) Reader::fail();
  BatchPart p;
  part_fields(p, r);
  const MixtureFile& m = p.mixture;
  const std::size_t S = m.slices(), K = std::size_t(std::max(m.kmax, 0));
  if (!r.done() || p.slice_index.size() != S || m.phi_o.size() != S || m.scale.size() != S ||
      m.loglik.size() != S || m.l1_rel.size() != S || m.defensive.size() != S || m.k.size() != S || m.weights.size() != S * K ||
      m.means.size() != 2 * S * K || m.covariances.size() != 3 * S * K ||
      (!m.rgb_scale.empty() && m.rgb_scale.size() != 3 * S * K) ||
      (!m.rgb_copies.empty() && (m.rgb_scale.empty() || m.rgb_copies.size() != kCopyValues * S * K)) || p.report.size() != S)
    Reader::fail();
  return p;
}

}  // namespace bsdfmix::scale
