// Crash-safe progress of a sweep: each finished batch is committed as its own part file
// (atomically) in `<output>.parts/`; a rerun with the same table and settings reuses them,
// so an interrupted sweep resumes where it stopped. Parts made under other settings
// (another fingerprint) are discarded. The parts stay on disk: the checkpoint holds their
// slice indices and hashes only, so its memory does not grow with the mixtures fitted.
#pragma once

#include <cstddef>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "io/mixture_file.hpp"
#include "sweep/fit_phases.hpp"
#include "sweep/fit_slices.hpp"

namespace bsdfmix {

// One committed batch: its slices' mixtures (a MixtureFile holding only them), their
// table slice indices, and their rows of the fit report and search CSVs.
struct BatchPart {
  std::vector<std::size_t> slice_index;
  MixtureFile mixture;
  std::vector<ReportRow> report;  // one per slice, in slice_index order
  std::vector<SearchRow> search;  // in slice order, each slice's rows in the order searched
  std::string slices_hash;        // content hash of the integrand weights of the slices it was fitted to
  FitPhases phases;               // where its fit's time went; not in the part file or a farm's message
};

// Where a committed part is and what it holds, without its mixtures and rows.
struct PartIndex {
  std::string path;
  std::vector<std::size_t> slice_index;
  std::string slices_hash;
};

class Checkpoint {
 public:
  // Opens (or starts) the parts directory of `output`; `fingerprint` identifies the
  // table and every setting that changes results.
  Checkpoint(const std::string& output, const std::string& fingerprint);

  // The committed parts, by the first slice index they hold.
  const std::map<std::size_t, PartIndex>& parts() const { return parts_; }
  // Reads the committed parts from their files in slice order and hands each to `use`:
  // one part in memory at a time.
  void each_part(const std::function<void(BatchPart&&)>& use) const;
  bool done(std::size_t slice_index) const;

  // Checks every committed part against the table as it is now: `hash_of` returns the
  // content hash of the given slices. On any mismatch every part is discarded (the
  // table was rewritten since), with a log line saying so.
  void verify(const std::function<std::string(const std::vector<std::size_t>&)>& hash_of);

  // Commits one part atomically (write to a temporary, then rename).
  void commit(const BatchPart& part);

  // Removes the parts directory once the final outputs are in place.
  void remove();

  const std::string& dir() const { return dir_; }

 private:
  void discard(const std::string& why);

  std::string dir_, fingerprint_;
  std::map<std::size_t, PartIndex> parts_;
  std::vector<bool> done_;
};

}  // namespace bsdfmix
