// A file sweep's outputs: the mixture file, the CSVs, the summary text, the fingerprint.
#include "sweep/sweep_outputs.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>
#include <type_traits>

#include "core/atomic_file.hpp"
#include "core/format.hpp"
#include "core/hash.hpp"
#include "core/stats.hpp"
#include "device/program.hpp"
#include "sweep/row_fields.hpp"

namespace bsdfmix {

namespace {

// A CSV or JSON number: non-finite values (a failed fit's) are written as 0.
std::string num(double v, const char* f = "%.9g") { return format_number(std::isfinite(v) ? v : 0.0, f); }

}  // namespace

namespace {

// A CSV of rows whose fields `fields` visits (sweep/row_fields.hpp): the names, then
// one line per row.
template <class Row, class Fields>
std::string rows_csv(const std::vector<Row>& rows, Fields fields) {
  std::ostringstream s;
  bool first = true;
  fields(Row{}, [&](const char* name, const auto&, CsvText) {
    s << (first ? "" : ",") << name;
    first = false;
  });
  s << "\n";
  for (const Row& row : rows) {
    first = true;
    fields(row, [&](const char*, const auto& v, CsvText text) {
      using T = std::decay_t<decltype(v)>;
      if (!first) s << ",";
      first = false;
      if constexpr (std::is_same_v<T, std::string>) s << v;
      else if constexpr (std::is_same_v<T, bool>) s << (v ? "1" : "0");
      else if constexpr (std::is_floating_point_v<T>) s << (text.nan_empty && std::isnan(v) ? "" : num(v, text.format));
      else s << v;
    });
    s << "\n";
  }
  return s.str();
}

}  // namespace

std::string report_csv(const std::vector<ReportRow>& rows) {
  return rows_csv(rows, [](const ReportRow& r, auto&& visit) { report_fields(r, visit); });
}

std::string search_csv(const std::vector<SearchRow>& rows) {
  return rows_csv(rows, [](const SearchRow& r, auto&& visit) { search_fields(r, visit); });
}

SweepSummary write_outputs(const SweepResult& result, const std::string& table_path, const TableMeta& meta,
                           const FitSettings& fit) {
  const MixtureFile& out = result.mixture;
  write_mixture_file(fit.output, out);
  write_text_atomic(fit.report, report_csv(result.report));
  write_text_atomic(fit.search_report, search_csv(result.search));

  SweepSummary sum;
  sum.slices = out.slices();
  sum.failed = result.failed();
  for (std::int32_t k : out.k) sum.k_histogram[k]++;
  sum.l1_median = quantile(out.l1_rel, 0.5);
  sum.l1_p90 = quantile(out.l1_rel, 0.9);
  sum.l1_max = quantile(out.l1_rel, 1.0);
  sum.mixture_file_bytes = std::filesystem::file_size(fit.output);
  sum.mixture_bytes = out.payload_bytes();
  sum.table_file_bytes = std::filesystem::file_size(table_path);
  sum.table_slices = meta.theta_o.size() * meta.phi_o.size();
  sum.table_bytes = std::uint64_t(sum.slices) * meta.cells_per_slice() * sizeof(float);
  sum.symmetry_factor = meta.azimuthal ? meta.phi_i.size() : 1;
  sum.full_bytes = sum.table_bytes * sum.symmetry_factor;
  return sum;
}

std::string sweep_fingerprint(const std::string& table_path, const TableMeta& meta, const std::vector<SliceRef>& plan,
                              const FitSettings& fit, std::size_t batch, const EmEngine& engine,
                              const std::vector<Device>& devices) {
  static const std::string executable = hex64(hash_file("/proc/self/exe"));
  std::string fit_sources;  // every program a fit runs
  for (const char* program : {"em", "l1", "amplitudes"}) fit_sources += kernel_source(program);
  std::ostringstream fp;
  fp << "table " << std::filesystem::absolute(table_path).string() << " size " << std::filesystem::file_size(table_path)
     << " source " << meta.source << "\nslices";
  for (const auto& r : plan) fp << ' ' << r.index;
  fp << "\nsettings " << fit_settings_json(fit) << "\nbatch " << batch << "\nbuild bsdfmix " << BSDFMIX_VERSION
     << " executable " << executable << " kernels " << Hash64().update(fit_sources.data(), fit_sources.size()).hex()
     << "\nnumeric path";
  for (std::size_t d = 0; d < devices.size(); ++d)
    fp << " [" << devices[d].info().name << " | " << devices[d].info().platform << " | "
       << devices[d].info().version << " | " << devices[d].info().driver << " | "
       << (engine.uses_fp64(d) ? "fp64" : "fp32") << " | " << engine.shape(d).label() << "]";
  fp << "\n";
  return fp.str();
}

std::string fit_settings_json(const FitSettings& f) {
  std::ostringstream s;
  s << "{\"k_min\": " << f.k_min << ", \"k_max\": " << f.k_max << ", \"seed\": " << f.seed
    << ", \"restarts\": " << f.restarts << ", \"final_restarts\": " << f.final_restarts
    << ", \"iterations\": " << f.iterations << ", \"final_iterations\": " << f.final_iterations
    << ", \"tolerance\": " << num(f.tolerance) << ", \"k_penalty\": " << num(f.k_penalty)
    << ", \"error_target\": " << (f.error_target ? num(*f.error_target) : "null")
    << ", \"search_pool\": " << f.search_pool << ", \"search\": \"" << search_name(f.search)
    << "\", \"refine\": \"" << f.refine << "\", \"refine_evaluations\": " << f.refine_evaluations
    << ", \"refine_kl\": " << num(f.refine_kl) << ", \"refine_rgb\": " << num(f.refine_rgb)
    << ", \"rgb_copies\": " << (f.rgb_copies ? num(*f.rgb_copies) : std::string("null"))
    << ", \"map\": \"" << f.map << "\""
    << ", \"criterion\": \"" << kCriterion << "\"}";
  return s.str();
}

double SweepSummary::cpu_utilization() const {
  return seconds > 0 ? cpu_seconds / (seconds * double(std::max(1u, cores))) : 0.0;
}

std::string SweepSummary::text() const {
  auto size = [](double b) {
    char buf[32];
    const char* u[] = {"B", "KiB", "MiB", "GiB", "TiB"};
    int i = 0;
    while (b >= 1024 && i < 4) b /= 1024, ++i;
    std::snprintf(buf, sizeof buf, "%.1f %s", b, u[i]);
    return std::string(buf);
  };
  std::ostringstream s;
  std::size_t total_k = 0;
  s << "  slices           " << slices << " fitted (" << resumed << " resumed from checkpoint, " << failed
    << " failed)\n  K per slice     ";
  for (auto [k, n] : k_histogram) {
    s << " " << k << "x" << n;
    total_k += std::size_t(k) * n;
  }
  char buf[256];
  std::snprintf(buf, sizeof buf, " (mean %.1f)\n", slices ? double(total_k) / double(slices) : 0.0);
  s << buf;
  if (!map.empty()) s << "  map              " << map << "\n";
  s << "  relative L1      median " << percent_text(l1_median) << ", p90 " << percent_text(l1_p90) << ", max "
    << percent_text(l1_max) << "\n";
  auto ratio = [](std::uint64_t a, std::uint64_t b) { return num(double(a) / double(std::max<std::uint64_t>(b, 1)), "%.0f") + "x"; };
  s << "  mixture          file " << size(double(mixture_file_bytes)) << " on disk, datasets " << size(double(mixture_bytes))
    << " (padded to the largest K)\n";
  s << "  table            file " << size(double(table_file_bytes)) << " on disk";
  if (table_slices == slices) s << " (" << ratio(table_file_bytes, mixture_file_bytes) << " the mixture file)";
  else s << " holding " << table_slices << " slices";
  s << ", float32 cells of the fitted slices " << size(double(table_bytes)) << " ("
    << ratio(table_bytes, mixture_bytes) << " the mixture's datasets)\n";
  if (symmetry_factor > 1)
    s << "  symmetry         azimuthal: one stored slice stands for " << symmetry_factor
      << " phi_o; without it those cells would be " << size(double(full_bytes)) << " ("
      << ratio(full_bytes, mixture_bytes) << " the mixture's datasets)\n";
  std::snprintf(buf, sizeof buf, "  wall time        %.1f s on %s\n", seconds, devices.c_str());
  s << buf;
  std::snprintf(buf, sizeof buf, "  cpu time         %.1f s: %.0f%% of %u cores over the wall time\n", cpu_seconds,
                100.0 * cpu_utilization(), cores);
  s << buf;
  if (!phases.text().empty()) s << "  time by phase    " << phases.text() << "\n";
  return s.str();
}

}  // namespace bsdfmix
