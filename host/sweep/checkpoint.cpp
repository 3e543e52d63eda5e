// Crash-safe progress of a sweep: one atomically written part file per finished batch.
#include "sweep/checkpoint.hpp"

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <type_traits>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "core/progress.hpp"
#include "io/h5.hpp"
#include "sweep/row_fields.hpp"

namespace bsdfmix {

namespace fs = std::filesystem;

namespace {

constexpr const char* kFingerprintFile = "fingerprint.txt";

h5::Handle string_type() {
  h5::Handle t(H5Tcopy(H5T_C_S1));
  H5Tset_size(t.get(), H5T_VARIABLE);
  H5Tset_cset(t.get(), H5T_CSET_UTF8);
  return t;
}

// The rows of a part travel as compound datasets of /mixture, one record per row: the
// fields of sweep/row_fields.hpp under their names, each at its natural alignment (as
// a C struct lays them out), strings as variable-length UTF-8.
template <class Row, class Fields>
class RowRecords {
 public:
  explicit RowRecords(Fields fields) : fields_(fields), str_(string_type()) {
    const Row row{};
    std::vector<std::pair<const char*, hid_t>> members;
    fields_(row, [&](const char* name, const auto& v) {
      const std::size_t size = member_size(v);
      size_ = (size_ + size - 1) / size * size;
      offsets_.push_back(size_);
      members.emplace_back(name, member_type(v));
      size_ += size;
    });
    size_ = (size_ + 7) / 8 * 8;
    type_ = h5::Handle(H5Tcreate(H5T_COMPOUND, size_));
    for (std::size_t i = 0; i < members.size(); ++i)
      H5Tinsert(type_.get(), members[i].first, offsets_[i], members[i].second);
  }

  void write(hid_t loc, const char* name, const std::vector<Row>& rows, const std::string& path) const {
    std::vector<std::uint64_t> buf(rows.size() * size_ / 8);  // 8-byte aligned records
    for (std::size_t i = 0; i < rows.size(); ++i) {
      std::uint8_t* record = reinterpret_cast<std::uint8_t*>(buf.data()) + i * size_;
      std::size_t f = 0;
      fields_(rows[i], [&](const char*, const auto& v) { put(record + offsets_[f++], v); });
    }
    const hsize_t n = rows.size();
    h5::Handle space(H5Screate_simple(1, &n, nullptr));
    h5::Handle d(H5Dcreate2(loc, name, type_.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT));
    if (!d.valid() || (n > 0 && H5Dwrite(d.get(), type_.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, buf.data()) < 0))
      throw IoError(path + ": cannot write /mixture/" + name);
  }

  std::vector<Row> read(hid_t loc, const char* name, const std::string& path) const {
    h5::Handle d = h5::open_dataset(loc, name, path);
    h5::Handle space(H5Dget_space(d.get()));
    const hssize_t n = space.valid() ? H5Sget_simple_extent_npoints(space.get()) : -1;
    if (n < 0) throw InputError(path + ": /mixture/" + name + " is unreadable");
    std::vector<Row> rows(static_cast<std::size_t>(n));
    if (n == 0) return rows;
    std::vector<std::uint64_t> buf(rows.size() * size_ / 8);
    if (H5Dread(d.get(), type_.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, buf.data()) < 0)
      throw InputError(path + ": /mixture/" + name + " is not a table of rows");
    struct Reclaim {  // frees the strings HDF5 allocated, also when copying them throws
      hid_t type, space;
      void* data;
      ~Reclaim() {
#if H5_VERSION_GE(1, 12, 0)
        H5Treclaim(type, space, H5P_DEFAULT, data);
#else
        H5Dvlen_reclaim(type, space, H5P_DEFAULT, data);
#endif
      }
    } reclaim{type_.get(), space.get(), buf.data()};
    for (std::size_t i = 0; i < rows.size(); ++i) {
      const std::uint8_t* record = reinterpret_cast<const std::uint8_t*>(buf.data()) + i * size_;
      std::size_t f = 0;
      fields_(rows[i], [&](const char*, auto& v) { get(record + offsets_[f++], v); });
    }
    return rows;
  }

 private:
  // std::size_t as uint64, int as int32, bool as uint8, strings as their C string.
  template <class T>
  static std::size_t member_size(const T&) {
    if constexpr (std::is_same_v<T, std::string>) return sizeof(const char*);
    else if constexpr (std::is_same_v<T, int>) return 4;
    else if constexpr (std::is_same_v<T, bool>) return 1;
    else return 8;
  }
  template <class T>
  hid_t member_type(const T&) const {
    if constexpr (std::is_same_v<T, std::string>) return str_.get();
    else if constexpr (std::is_same_v<T, int>) return H5T_NATIVE_INT32;
    else if constexpr (std::is_same_v<T, bool>) return H5T_NATIVE_UINT8;
    else if constexpr (std::is_same_v<T, double>) return H5T_NATIVE_DOUBLE;
    else return H5T_NATIVE_UINT64;
  }
  template <class T>
  static void put(std::uint8_t* at, const T& v) {
    if constexpr (std::is_same_v<T, std::string>) store(at, v.c_str());
    else if constexpr (std::is_same_v<T, int>) store(at, std::int32_t(v));
    else if constexpr (std::is_same_v<T, bool>) store(at, std::uint8_t(v));
    else if constexpr (std::is_same_v<T, double>) store(at, v);
    else store(at, std::uint64_t(v));
  }
  template <class T>
  static void get(const std::uint8_t* at, T& v) {
    if constexpr (std::is_same_v<T, std::string>) {
      const char* s = load<const char*>(at);
      v = s ? s : "";
    } else if constexpr (std::is_same_v<T, int>) v = load<std::int32_t>(at);
    else if constexpr (std::is_same_v<T, bool>) v = load<std::uint8_t>(at) != 0;
    else if constexpr (std::is_same_v<T, double>) v = load<double>(at);
    else v = T(load<std::uint64_t>(at));
  }
  template <class T>
  static void store(std::uint8_t* at, T v) { std::memcpy(at, &v, sizeof v); }
  template <class T>
  static T load(const std::uint8_t* at) {
    T v;
    std::memcpy(&v, at, sizeof v);
    return v;
  }

  Fields fields_;
  h5::Handle str_, type_;
  std::size_t size_ = 0;
  std::vector<std::size_t> offsets_;
};

// The fields of each row, without their CSV text (sweep/row_fields.hpp).
struct ReportFields {
  template <class Row, class Visit>
  void operator()(Row& r, Visit&& visit) const {
    report_fields(r, [&](const char* name, auto& v, CsvText) { visit(name, v); });
  }
};
struct SearchFields {
  template <class Row, class Visit>
  void operator()(Row& r, Visit&& visit) const {
    search_fields(r, [&](const char* name, auto& v, CsvText) { visit(name, v); });
  }
};
using ReportRecords = RowRecords<ReportRow, ReportFields>;
using SearchRecords = RowRecords<SearchRow, SearchFields>;

// A part is a mixture file with three more attributes and two row datasets on /mixture.
BatchPart read_part(const std::string& path) {
  BatchPart part;
  part.mixture = read_mixture_file(path);
  h5::Handle f = h5::open_file(path);
  h5::Handle g = h5::open_group(f.get(), "mixture", path);
  part.slices_hash = h5::read_string_attr(g.get(), "slices_hash", path);
  std::istringstream idx(h5::read_string_attr(g.get(), "slice_index", path));
  std::size_t s;
  while (idx >> s) part.slice_index.push_back(s);
  if (part.slice_index.size() != part.mixture.slices())
    throw InputError(path + ": slice_index does not match the slices held");
  part.report = ReportRecords(ReportFields{}).read(g.get(), "report_rows", path);
  part.search = SearchRecords(SearchFields{}).read(g.get(), "search_rows", path);
  if (part.report.size() != part.slice_index.size())
    throw InputError(path + ": report_rows does not match the slices held");
  return part;
}

void write_part(const std::string& path, const BatchPart& part) {
  AtomicOutput out(path);
  {
    h5::Handle f = h5::create_file(out.temp_path());
    write_mixture_group(f.get(), part.mixture, path);
    h5::Handle g = h5::open_group(f.get(), "mixture", path);
    std::ostringstream idx;
    for (std::size_t s : part.slice_index) idx << s << ' ';
    h5::write_string_attr(g.get(), "slice_index", idx.str(), path);
    h5::write_string_attr(g.get(), "slices_hash", part.slices_hash, path);
    ReportRecords(ReportFields{}).write(g.get(), "report_rows", part.report, path);
    SearchRecords(SearchFields{}).write(g.get(), "search_rows", part.search, path);
    if (H5Fflush(f.get(), H5F_SCOPE_GLOBAL) < 0) throw IoError(path + ": flush failed (disk full?)");
  }
  out.commit();
}

}  // namespace

Checkpoint::Checkpoint(const std::string& output, const std::string& fingerprint)
    : dir_(output + ".parts"), fingerprint_(fingerprint) {
  const fs::path dir(dir_);
  if (fs::exists(dir)) {
    const fs::path fp = dir / kFingerprintFile;
    if (read_text(fp.string()).value_or("") != fingerprint_)
      discard("made with another table, other settings, another build or another numeric path");
  }
  if (!fs::exists(dir)) return;  // created by the first commit: a failed run leaves nothing
  std::size_t resumed = 0;
  for (const auto& e : fs::directory_iterator(dir)) {
    const std::string name = e.path().filename().string();
    if (name.rfind("batch_", 0) != 0 || e.path().extension() != ".h5") {
      if (name.find(".partial-") != std::string::npos)
        fs::remove(e.path());  // left by a killed writer
      continue;
    }
    try {
      BatchPart p = read_part(e.path().string());
      if (p.slice_index.empty()) continue;
      for (std::size_t s : p.slice_index) {
        if (s >= done_.size()) done_.resize(s + 1, false);
        done_[s] = true;
      }
      resumed += p.slice_index.size();
      parts_.emplace(p.slice_index.front(), PartIndex{e.path().string(), p.slice_index, p.slices_hash});
    } catch (const Error& err) {
      log_line("discarding unreadable part " + e.path().string() + ": " + err.what());
      fs::remove(e.path());
    }
  }
  if (resumed) log_line("resuming: " + std::to_string(resumed) + " slice(s) already fitted in " + dir_);
}

void Checkpoint::discard(const std::string& why) {
  log_line("discarding " + dir_ + ": " + why);
  std::error_code ec;
  fs::remove_all(dir_, ec);
  if (ec) throw IoError(dir_ + ": cannot remove stale checkpoint: " + ec.message());
  parts_.clear();
  done_.clear();
}

void Checkpoint::verify(const std::function<std::string(const std::vector<std::size_t>&)>& hash_of) {
  for (const auto& [first, part] : parts_)
    if (hash_of(part.slice_index) != part.slices_hash) {
      discard("the table's content changed since slice " + std::to_string(first) + " was fitted");
      return;
    }
}

bool Checkpoint::done(std::size_t s) const { return s < done_.size() && done_[s]; }

void Checkpoint::commit(const BatchPart& part) {
  if (part.slice_index.empty()) return;
  const fs::path dir(dir_);
  if (!fs::exists(dir / kFingerprintFile)) {
    std::error_code ec;
    fs::create_directories(dir, ec);
    if (ec) throw IoError(dir_ + ": cannot create checkpoint directory: " + ec.message());
    fsync_directory(dir_);
    write_text_atomic((dir / kFingerprintFile).string(), fingerprint_);
  }
  const std::string path = (fs::path(dir_) / ("batch_" + std::to_string(part.slice_index.front()) + ".h5")).string();
  write_part(path, part);
  for (std::size_t s : part.slice_index) {
    if (s >= done_.size()) done_.resize(s + 1, false);
    done_[s] = true;
  }
  parts_[part.slice_index.front()] = PartIndex{path, part.slice_index, part.slices_hash};
}

void Checkpoint::each_part(const std::function<void(BatchPart&&)>& use) const {
  for (const auto& [first, index] : parts_) {
    BatchPart part = read_part(index.path);
    if (part.slice_index != index.slice_index) throw IoError(index.path + ": changed since it was committed");
    use(std::move(part));
  }
}

void Checkpoint::remove() {
  std::error_code ec;
  fs::remove_all(dir_, ec);
}

}  // namespace bsdfmix
