// BatchPart <-> bytes: a versioned header, then every field in a fixed order, each
// vector as its length followed by its raw elements, each list of report or search
// rows as its length followed by every row's fields (strings: length, then bytes).
#include "scale/part_codec.hpp"

#include <algorithm>
#include <cstring>
#include <type_traits>

#include "core/error.hpp"

namespace bsdfmix::scale {

namespace {

constexpr std::uint32_t kMagic = 0x42504D58;  // "XMPB"
// The fewest bytes a report row (9 numbers, two string lengths) and a search row take.
constexpr std::size_t kReportRowBytes = 8 + 8 + 8 + 4 + 4 + 8 + 8 + 8 + 8 + 8 + 8 + 8;
constexpr std::size_t kSearchRowBytes = 8 + 4 + 4 + 8 + 8 + 8 + 1;
// 2: the report and search rows as fields, not CSV text; 3: rgb_scale and the rows' RGB errors;
// 4: rgb_copies
constexpr std::uint32_t kVersion = 4;

class Writer {
 public:
  template <class T>
  void pod(const T& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    const auto* p = reinterpret_cast<const std::uint8_t*>(&v);
    out.insert(out.end(), p, p + sizeof(T));
  }
  template <class T>
  void vec(const std::vector<T>& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    pod(std::uint64_t(v.size()));
    const auto* p = reinterpret_cast<const std::uint8_t*>(v.data());
    out.insert(out.end(), p, p + v.size() * sizeof(T));
  }
  void str(const std::string& s) {
    pod(std::uint64_t(s.size()));
    out.insert(out.end(), s.begin(), s.end());
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
  template <class T>
  std::vector<T> vec() {
    const std::uint64_t n = pod<std::uint64_t>();
    if (n > (size_ - at_) / sizeof(T)) fail();
    std::vector<T> v(n);
    take(v.data(), n * sizeof(T));
    return v;
  }
  std::string str() {
    const std::uint64_t n = pod<std::uint64_t>();
    if (n > size_ - at_) fail();
    std::string s(reinterpret_cast<const char*>(data_ + at_), n);
    at_ += n;
    return s;
  }
  // A count of records of at least `min_bytes` each: refused when the bytes left cannot hold them.
  std::size_t count(std::size_t min_bytes) {
    const std::uint64_t n = pod<std::uint64_t>();
    if (n > (size_ - at_) / min_bytes) fail();
    return std::size_t(n);
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

}  // namespace

std::vector<std::uint8_t> encode_part(const BatchPart& p) {
  Writer w;
  w.pod(kMagic);
  w.pod(kVersion);
  std::vector<std::uint64_t> idx(p.slice_index.begin(), p.slice_index.end());
  w.vec(idx);
  const MixtureFile& m = p.mixture;
  w.pod(std::int32_t(m.domain));
  w.pod(std::uint8_t(m.azimuthal));
  w.str(m.table_source);
  w.str(m.fit_settings);
  w.vec(m.table_theta_o);
  w.vec(m.table_phi_o);
  w.vec(m.theta_o);
  w.vec(m.phi_o);
  w.vec(m.scale);
  w.vec(m.loglik);
  w.vec(m.l1_rel);
  w.vec(m.k);
  w.pod(std::int32_t(m.kmax));
  w.vec(m.weights);
  w.vec(m.means);
  w.vec(m.covariances);
  w.vec(m.rgb_scale);
  w.vec(m.rgb_copies);
  w.pod(std::uint64_t(p.report.size()));
  for (const ReportRow& r : p.report) {
    w.pod(std::uint64_t(r.slice));
    w.pod(r.theta_o);
    w.pod(r.phi_o);
    w.pod(std::int32_t(r.k));
    w.pod(std::int32_t(r.iterations));
    w.pod(r.loglik);
    w.pod(r.l1_rel);
    w.pod(r.seconds);
    w.str(r.device);
    w.str(r.status);
    w.pod(r.rgb_l1_rel);
    w.pod(r.rgb_negative);
  }
  w.pod(std::uint64_t(p.search.size()));
  for (const SearchRow& r : p.search) {
    w.pod(std::uint64_t(r.slice));
    w.pod(std::int32_t(r.k));
    w.pod(std::int32_t(r.restart));
    w.pod(r.loglik);
    w.pod(r.l1_rel);
    w.pod(r.score);
    w.pod(std::uint8_t(r.chosen));
  }
  w.str(p.slices_hash);
  return std::move(w.out);
}

BatchPart decode_part(const std::uint8_t* data, std::size_t size) {
  Reader r(data, size);
  if (r.pod<std::uint32_t>() != kMagic || r.pod<std::uint32_t>() != kVersion) Reader::fail();
  BatchPart p;
  for (std::uint64_t i : r.vec<std::uint64_t>()) p.slice_index.push_back(std::size_t(i));
  MixtureFile& m = p.mixture;
  m.domain = static_cast<Domain>(r.pod<std::int32_t>());
  m.azimuthal = r.pod<std::uint8_t>() != 0;
  m.table_source = r.str();
  m.fit_settings = r.str();
  m.table_theta_o = r.vec<double>();
  m.table_phi_o = r.vec<double>();
  m.theta_o = r.vec<double>();
  m.phi_o = r.vec<double>();
  m.scale = r.vec<double>();
  m.loglik = r.vec<double>();
  m.l1_rel = r.vec<double>();
  m.k = r.vec<std::int32_t>();
  m.kmax = r.pod<std::int32_t>();
  m.weights = r.vec<float>();
  m.means = r.vec<float>();
  m.covariances = r.vec<float>();
  m.rgb_scale = r.vec<double>();
  m.rgb_copies = r.vec<double>();
  p.report.resize(r.count(kReportRowBytes));
  for (ReportRow& row : p.report) {
    row.slice = std::size_t(r.pod<std::uint64_t>());
    row.theta_o = r.pod<double>();
    row.phi_o = r.pod<double>();
    row.k = r.pod<std::int32_t>();
    row.iterations = r.pod<std::int32_t>();
    row.loglik = r.pod<double>();
    row.l1_rel = r.pod<double>();
    row.seconds = r.pod<double>();
    row.device = r.str();
    row.status = r.str();
    row.rgb_l1_rel = r.pod<double>();
    row.rgb_negative = r.pod<double>();
  }
  p.search.resize(r.count(kSearchRowBytes));
  for (SearchRow& row : p.search) {
    row.slice = std::size_t(r.pod<std::uint64_t>());
    row.k = r.pod<std::int32_t>();
    row.restart = r.pod<std::int32_t>();
    row.loglik = r.pod<double>();
    row.l1_rel = r.pod<double>();
    row.score = r.pod<double>();
    const std::uint8_t chosen = r.pod<std::uint8_t>();
    if (chosen > 1) Reader::fail();
    row.chosen = chosen != 0;
  }
  p.slices_hash = r.str();
  const std::size_t S = m.slices(), K = std::size_t(std::max(m.kmax, 0));
  if (!r.done() || p.slice_index.size() != S || m.phi_o.size() != S || m.scale.size() != S ||
      m.loglik.size() != S || m.l1_rel.size() != S || m.k.size() != S || m.weights.size() != S * K ||
      m.means.size() != 2 * S * K || m.covariances.size() != 3 * S * K ||
      (!m.rgb_scale.empty() && m.rgb_scale.size() != 3 * S * K) ||
      (!m.rgb_copies.empty() && (m.rgb_scale.empty() || m.rgb_copies.size() != kCopyValues * S * K)) || p.report.size() != S)
    Reader::fail();
  return p;
}

}  // namespace bsdfmix::scale
