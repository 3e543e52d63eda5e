// The stand-in command's candidates: one fit of every table row per K cap (reused when the
// work directory already holds it), and each stride's subset of it, packed and compared.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <system_error>

#include "compare/compare.hpp"
#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "core/progress.hpp"
#include "io/mixture_file.hpp"
#include "io/table.hpp"
#include "standin/standin_internal.hpp"
#include "sweep/slice_plan.hpp"
#include "sweep/sweep.hpp"

namespace bsdfmix {

namespace {

std::string work_path(const StandinOptions& o, const std::string& name) {
  return (std::filesystem::path(o.work) / name).string();
}

// The seconds a finished fit took, as its seconds file records them; nullopt without one.
std::optional<double> read_seconds(const std::string& path) {
  std::ifstream in(path);
  double s = 0;
  if (in >> s) return s;
  return std::nullopt;
}

// The all-rows fit at `cap` in the work directory is this table's, with these settings.
bool fit_is_current(const std::string& path, const FitSettings& fit, const TableMeta& meta) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) return false;
  try {
    const MixtureFile m = read_mixture_file(path);
    return m.fit_settings == fit_settings_json(fit) && m.table_source == meta.source &&
           m.table_theta_o == meta.theta_o && m.table_phi_o == meta.phi_o && m.slices() == meta.n_slices();
  } catch (const Error&) {
    return false;  // a file from elsewhere: fitted again
  }
}

}  // namespace

CapFit fit_all_rows(const StandinOptions& o, const TableMeta& meta, int cap) {
  FitSettings fit = o.fit;
  fit.k_max = cap;
  fit.k_min = std::min(fit.k_min, cap);
  fit.theta_o.clear();
  fit.phi_o.clear();
  fit.theta_o_stride = 0;
  fit.theta_o_rows.clear();
  fit.theta_o_deg.clear();
  const std::string stem = "k" + std::to_string(cap);
  fit.output = work_path(o, stem + ".h5");
  fit.report = work_path(o, stem + "_fit.csv");
  fit.search_report = work_path(o, stem + "_search.csv");
  const std::string seconds_file = work_path(o, stem + "_seconds.txt");
  CapFit out;
  const std::optional<double> seconds = read_seconds(seconds_file);
  if (seconds && fit_is_current(fit.output, fit, meta)) {
    log_line("standin: K cap " + std::to_string(cap) + ": reusing " + fit.output);
    out.seconds = *seconds;
  } else {
    log_line("standin: K cap " + std::to_string(cap) + ": fitting all " + std::to_string(meta.n_slices()) +
             " slices into " + fit.output);
    const SweepSummary s = run_sweep(o.table, fit, o.device);
    out.seconds = s.seconds;
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.3f\n", s.seconds);
    write_text_atomic(seconds_file, buf);
  }
  out.mixture = read_mixture_file(fit.output);
  return out;
}

StandinCandidate measure_candidate(const StandinOptions& o, const TableMeta& meta, const CapFit& fit, int stride, int cap) {
  const std::vector<std::size_t> rows = stride_rows(meta.theta_o.size(), std::size_t(stride));
  std::vector<bool> keep(meta.theta_o.size(), false);
  for (std::size_t r : rows) keep[r] = true;
  MixtureFile sub = fit.mixture.header_only();
  for (std::size_t s = 0; s < fit.mixture.slices(); ++s)
    if (keep[nearest_center(meta.theta_o, fit.mixture.theta_o[s])]) sub.add_slice_from(fit.mixture, s);
  sub.storage = parse_storage("ragged_f32", "standin");
  StandinCandidate c;
  c.stride = stride;
  c.k_cap = cap;
  c.rows = rows.size();
  c.path = work_path(o, "s" + std::to_string(stride) + "_k" + std::to_string(cap) + ".h5");
  write_mixture_file(c.path, sub);
  c.bytes = sub.payload_bytes();
  c.file_bytes = std::filesystem::file_size(c.path);
  const Comparison cmp = compare_stand_in(c.path, o.table);
  c.median = comparison_error(cmp, 0.5);
  c.p90 = comparison_error(cmp, 0.9);
  c.fit_seconds = fit.seconds * double(rows.size()) / double(meta.theta_o.size());
  return c;
}

}  // namespace bsdfmix
