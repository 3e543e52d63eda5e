// Crash-safe progress of a sweep: one atomically written part file per finished batch.
#include "sweep/checkpoint.hpp"

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

std::string slurp(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  std::ostringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

// A part is a mixture file with three extra attributes on /mixture.
BatchPart read_part(const std::string& path) {
  BatchPart part;
  part.mixture = read_mixture_file(path);
  h5::Handle f = h5::open_file(path);
  h5::Handle g = h5::open_group(f.get(), "mixture", path);
  part.report_rows = h5::read_string_attr(g.get(), "report_rows", path);
  part.search_rows = h5::read_string_attr(g.get(), "search_rows", path);
  part.slices_hash = h5::read_string_attr(g.get(), "slices_hash", path);
  std::istringstream idx(h5::read_string_attr(g.get(), "slice_index", path));
  std::size_t s;
  while (idx >> s) part.slice_index.push_back(s);
  if (part.slice_index.size() != part.mixture.slices())
    throw InputError(path + ": slice_index does not match the slices held");
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
    h5::write_string_attr(g.get(), "report_rows", part.report_rows, path);
    h5::write_string_attr(g.get(), "search_rows", part.search_rows, path);
    h5::write_string_attr(g.get(), "slices_hash", part.slices_hash, path);
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
    if (!fs::exists(fp) || slurp(fp) != fingerprint_)
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
