// Crash-safe progress of a sweep: one atomically written part file per finished batch.
#include "sweep/checkpoint.hpp"

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "core/progress.hpp"
#include "io/h5.hpp"

namespace bsdfmix {

namespace fs = std::filesystem;

namespace {

const char* kFingerprintFile = "fingerprint.txt";

// The rows of a part travel as compound datasets of /mixture, one record per row.
struct ReportRecord {
  std::uint64_t slice;
  double theta_o, phi_o;
  std::int32_t k, iterations;
  double loglik, l1_rel, seconds;
  const char* device;
  const char* status;
  double rgb_l1_rel, rgb_negative;
};
struct SearchRecord {
  std::uint64_t slice;
  std::int32_t k, restart;
  double loglik, l1_rel, score;
  std::uint8_t chosen;
};

h5::Handle string_type() {
  h5::Handle t(H5Tcopy(H5T_C_S1));
  H5Tset_size(t.get(), H5T_VARIABLE);
  H5Tset_cset(t.get(), H5T_CSET_UTF8);
  return t;
}

h5::Handle report_type(hid_t str) {
  h5::Handle t(H5Tcreate(H5T_COMPOUND, sizeof(ReportRecord)));
  H5Tinsert(t.get(), "slice", HOFFSET(ReportRecord, slice), H5T_NATIVE_UINT64);
  H5Tinsert(t.get(), "theta_o", HOFFSET(ReportRecord, theta_o), H5T_NATIVE_DOUBLE);
  H5Tinsert(t.get(), "phi_o", HOFFSET(ReportRecord, phi_o), H5T_NATIVE_DOUBLE);
  H5Tinsert(t.get(), "k", HOFFSET(ReportRecord, k), H5T_NATIVE_INT32);
  H5Tinsert(t.get(), "iterations", HOFFSET(ReportRecord, iterations), H5T_NATIVE_INT32);
  H5Tinsert(t.get(), "loglik", HOFFSET(ReportRecord, loglik), H5T_NATIVE_DOUBLE);
  H5Tinsert(t.get(), "l1_rel", HOFFSET(ReportRecord, l1_rel), H5T_NATIVE_DOUBLE);
  H5Tinsert(t.get(), "seconds", HOFFSET(ReportRecord, seconds), H5T_NATIVE_DOUBLE);
  H5Tinsert(t.get(), "device", HOFFSET(ReportRecord, device), str);
  H5Tinsert(t.get(), "status", HOFFSET(ReportRecord, status), str);
  H5Tinsert(t.get(), "rgb_l1_rel", HOFFSET(ReportRecord, rgb_l1_rel), H5T_NATIVE_DOUBLE);
  H5Tinsert(t.get(), "rgb_negative", HOFFSET(ReportRecord, rgb_negative), H5T_NATIVE_DOUBLE);
  return t;
}

h5::Handle search_type() {
  h5::Handle t(H5Tcreate(H5T_COMPOUND, sizeof(SearchRecord)));
  H5Tinsert(t.get(), "slice", HOFFSET(SearchRecord, slice), H5T_NATIVE_UINT64);
  H5Tinsert(t.get(), "k", HOFFSET(SearchRecord, k), H5T_NATIVE_INT32);
  H5Tinsert(t.get(), "restart", HOFFSET(SearchRecord, restart), H5T_NATIVE_INT32);
  H5Tinsert(t.get(), "loglik", HOFFSET(SearchRecord, loglik), H5T_NATIVE_DOUBLE);
  H5Tinsert(t.get(), "l1_rel", HOFFSET(SearchRecord, l1_rel), H5T_NATIVE_DOUBLE);
  H5Tinsert(t.get(), "score", HOFFSET(SearchRecord, score), H5T_NATIVE_DOUBLE);
  H5Tinsert(t.get(), "chosen", HOFFSET(SearchRecord, chosen), H5T_NATIVE_UINT8);
  return t;
}

template <class Record>
void write_records(hid_t loc, const char* name, hid_t type, const std::vector<Record>& records,
                   const std::string& path) {
  const hsize_t n = records.size();
  h5::Handle space(H5Screate_simple(1, &n, nullptr));
  h5::Handle d(H5Dcreate2(loc, name, type, space.get(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT));
  if (!d.valid() || (n > 0 && H5Dwrite(d.get(), type, H5S_ALL, H5S_ALL, H5P_DEFAULT, records.data()) < 0))
    throw IoError(path + ": cannot write /mixture/" + name);
}

// Reads the records of a dataset and hands them to `take` (which copies what it keeps:
// the strings are freed after).
template <class Record, class Take>
void read_records(hid_t loc, const char* name, hid_t type, const std::string& path, Take take) {
  h5::Handle d = h5::open_dataset(loc, name, path);
  h5::Handle space(H5Dget_space(d.get()));
  const hssize_t n = space.valid() ? H5Sget_simple_extent_npoints(space.get()) : -1;
  if (n < 0) throw InputError(path + ": /mixture/" + name + " is unreadable");
  std::vector<Record> records(static_cast<std::size_t>(n));
  if (n == 0) return;
  if (H5Dread(d.get(), type, H5S_ALL, H5S_ALL, H5P_DEFAULT, records.data()) < 0)
    throw InputError(path + ": /mixture/" + name + " is not a table of rows");
  struct Reclaim {  // frees the strings HDF5 allocated, also when `take` throws
    hid_t type, space;
    void* data;
    ~Reclaim() {
#if H5_VERSION_GE(1, 12, 0)
      H5Treclaim(type, space, H5P_DEFAULT, data);
#else
      H5Dvlen_reclaim(type, space, H5P_DEFAULT, data);
#endif
    }
  } reclaim{type, space.get(), records.data()};
  for (const Record& r : records) take(r);
}

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
  const h5::Handle str = string_type(), report = report_type(str.get()), search = search_type();
  read_records<ReportRecord>(g.get(), "report_rows", report.get(), path, [&](const ReportRecord& r) {
    part.report.push_back({std::size_t(r.slice), r.theta_o, r.phi_o, r.k, r.iterations, r.loglik, r.l1_rel,
                           r.seconds, r.device ? r.device : "", r.status ? r.status : "", r.rgb_l1_rel, r.rgb_negative});
  });
  read_records<SearchRecord>(g.get(), "search_rows", search.get(), path, [&](const SearchRecord& r) {
    part.search.push_back({std::size_t(r.slice), r.k, r.restart, r.loglik, r.l1_rel, r.score, r.chosen != 0});
  });
  if (part.report.size() != part.slice_index.size())
    throw InputError(path + ": report_rows does not match the slices held");
  return part;
}

void write_part(const std::string& path, const BatchPart& part) {
  std::vector<ReportRecord> report;
  for (const ReportRow& r : part.report)
    report.push_back({r.slice, r.theta_o, r.phi_o, r.k, r.iterations, r.loglik, r.l1_rel, r.seconds,
                      r.device.c_str(), r.status.c_str(), r.rgb_l1_rel, r.rgb_negative});
  std::vector<SearchRecord> search;
  for (const SearchRow& r : part.search)
    search.push_back({r.slice, r.k, r.restart, r.loglik, r.l1_rel, r.score, std::uint8_t(r.chosen)});
  AtomicOutput out(path);
  {
    h5::Handle f = h5::create_file(out.temp_path());
    write_mixture_group(f.get(), part.mixture, path);
    h5::Handle g = h5::open_group(f.get(), "mixture", path);
    std::ostringstream idx;
    for (std::size_t s : part.slice_index) idx << s << ' ';
    h5::write_string_attr(g.get(), "slice_index", idx.str(), path);
    h5::write_string_attr(g.get(), "slices_hash", part.slices_hash, path);
    const h5::Handle str = string_type(), report_t = report_type(str.get()), search_t = search_type();
    write_records(g.get(), "report_rows", report_t.get(), report, path);
    write_records(g.get(), "search_rows", search_t.get(), search, path);
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
      parts_.emplace(p.slice_index.front(), std::move(p));
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
  parts_[part.slice_index.front()] = part;
}

void Checkpoint::remove() {
  std::error_code ec;
  fs::remove_all(dir_, ec);
}

}  // namespace bsdfmix
