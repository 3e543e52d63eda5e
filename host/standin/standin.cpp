// The stand-in command: K caps in increasing order, each stride's subset measured, and the
// smallest candidate meeting the target within the budget chosen.
#include "standin/standin.hpp"

#include <algorithm>
#include <filesystem>
#include <set>
#include <sstream>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "core/format.hpp"
#include "core/progress.hpp"
#include "io/mixture_file.hpp"
#include "io/table.hpp"
#include "standin/standin_internal.hpp"
#include "sweep/map_choice.hpp"
#include "sweep/slice_plan.hpp"

namespace bsdfmix {

namespace {

std::string percent(double v) { return format_number(100 * v, "%.2f") + "%"; }

double metric(const StandinOptions& o, const StandinCandidate& c) { return o.p90 ? c.p90 : c.median; }

std::string metric_name(const StandinOptions& o, bool rgb) {
  return std::string(o.p90 ? "p90 " : "median ") + (rgb ? "RGB error" : "relative L1");
}

// Stride 1 (every row: when it meets the target, raising K stops), then the strides whose
// row sets differ on n rows, in the order given (a stride past the axis keeps the first
// and last row only).
std::vector<int> distinct_strides(const std::vector<int>& strides, std::size_t n) {
  std::set<std::vector<std::size_t>> seen;
  std::vector<int> out;
  std::vector<int> all{1};
  all.insert(all.end(), strides.begin(), strides.end());
  for (int s : all)
    if (seen.insert(stride_rows(n, std::size_t(s))).second) out.push_back(s);
  return out;
}

std::string describe(const StandinOptions& o, const StandinResult& r, const StandinCandidate& c) {
  return "stride " + std::to_string(c.stride) + " (" + std::to_string(c.rows) + " rows), K cap " +
         std::to_string(c.k_cap) + ": " + std::to_string(c.bytes) + " bytes, " + metric_name(o, r.rgb) + " " +
         percent(metric(o, c));
}

// Sets chosen (or closest) and why.
void choose(const StandinOptions& o, StandinResult& r) {
  const auto within = [&](const StandinCandidate& c) { return o.max_bytes == 0 || c.bytes <= o.max_bytes; };
  std::size_t meeting = 0;
  for (std::size_t i = 0; i < r.candidates.size(); ++i) {
    const StandinCandidate& c = r.candidates[i];
    if (!within(c) || metric(o, c) > o.target) continue;
    ++meeting;
    if (!r.chosen || c.bytes < r.candidates[*r.chosen].bytes ||
        (c.bytes == r.candidates[*r.chosen].bytes && metric(o, c) < metric(o, r.candidates[*r.chosen])))
      r.chosen = i;
  }
  const std::string target = metric_name(o, r.rgb) + " <= " + format_number(100 * o.target, "%.3g") + "%" +
                             (o.max_bytes ? " within " + std::to_string(o.max_bytes) + " bytes" : "");
  if (r.chosen) {
    r.why = "chose " + describe(o, r, r.candidates[*r.chosen]) + ": the fewest bytes of the " +
            std::to_string(meeting) + " candidates meeting " + target;
    return;
  }
  const bool any_within = std::any_of(r.candidates.begin(), r.candidates.end(), within);
  for (std::size_t i = 0; i < r.candidates.size(); ++i) {
    const StandinCandidate& c = r.candidates[i], &best = r.candidates[r.closest];
    if (any_within && !within(c)) continue;
    if ((any_within && !within(best)) || metric(o, c) < metric(o, best)) r.closest = i;
  }
  r.why = "no candidate meets " + target + "; the closest: " + describe(o, r, r.candidates[r.closest]) + " (" +
          r.candidates[r.closest].path + ")";
}

}  // namespace

std::string default_work_dir(const std::string& output) {
  std::filesystem::path p(output);
  if (p.extension() == ".h5") p.replace_extension();
  return p.string() + ".standin";
}

StandinResult choose_stand_in(const StandinOptions& o) {
  if (o.k_caps.empty() || o.strides.empty()) throw InputError("standin: give at least one K cap and one stride");
  const TableReader reader(o.table);
  const TableMeta& meta = reader.meta();
  StandinResult r;
  r.rgb = meta.rgb;
  prepare_output(o.work + "/k.h5", 1 << 20);
  const std::vector<int> strides = distinct_strides(o.strides, meta.theta_o.size());
  Progress progress("standin " + o.table, o.k_caps.size(), "K caps");
  int left = -1;  // caps still to fit once every row meets the target
  StandinOptions fitting = o;  // fit.map auto: the first cap's probe chooses the map of every cap
  for (int cap : o.k_caps) {
    const CapFit fit = fit_all_rows(fitting, meta, cap);
    if (map_probed(fitting.fit, meta.domain))
      fitting.fit.map = map_setting(fit.mixture.map);
    bool all_rows_meet = false;
    for (int s : strides) {
      r.candidates.push_back(measure_candidate(o, meta, fit, s, cap));
      const StandinCandidate& c = r.candidates.back();
      log_line("standin: " + describe(o, r, c));
      if (c.rows == meta.theta_o.size() && metric(o, c) <= o.target) all_rows_meet = true;
    }
    progress.advance();
    if (left < 0 && all_rows_meet) left = o.extra_caps;
    else if (left > 0) --left;
    if (left == 0) break;
  }
  progress.finish();
  choose(o, r);
  return r;
}

std::string candidates_table(const StandinResult& r) {
  std::ostringstream s;
  s << "  stride  rows  k_max     bytes  file_bytes   median      p90    fit_s\n";
  for (std::size_t i = 0; i < r.candidates.size(); ++i) {
    const StandinCandidate& c = r.candidates[i];
    char buf[160];
    std::snprintf(buf, sizeof buf, "%c %6d %5zu %6d %9llu %11llu %7.2f%% %7.2f%% %8.1f\n",
                  r.chosen && *r.chosen == i ? '*' : ' ', c.stride, c.rows, c.k_cap,
                  static_cast<unsigned long long>(c.bytes), static_cast<unsigned long long>(c.file_bytes),
                  100 * c.median, 100 * c.p90, c.fit_seconds);
    s << buf;
  }
  return s.str();
}

std::string candidates_csv(const StandinResult& r) {
  std::ostringstream s;
  s << "stride,rows,k_max,bytes,file_bytes,median,p90,fit_seconds,chosen,file\n";
  for (std::size_t i = 0; i < r.candidates.size(); ++i) {
    const StandinCandidate& c = r.candidates[i];
    s << c.stride << "," << c.rows << "," << c.k_cap << "," << c.bytes << "," << c.file_bytes << ","
      << format_number(c.median, "%.6g") << "," << format_number(c.p90, "%.6g") << ","
      << format_number(c.fit_seconds, "%.2f") << "," << (r.chosen && *r.chosen == i ? 1 : 0) << "," << c.path
      << "\n";
  }
  return s.str();
}

void write_stand_in(const StandinResult& r, const std::string& output) {
  if (!r.chosen) throw InputError(r.why);
  write_mixture_file(output, read_mixture_file(r.candidates[*r.chosen].path));
}

}  // namespace bsdfmix
