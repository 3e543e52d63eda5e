// Fit time and fit error against K for chosen slices.
#include "sweep/k_timing.hpp"

#include <chrono>
#include <cstdio>
#include <sstream>

#include "core/atomic_file.hpp"
#include "core/progress.hpp"
#include "device/device.hpp"
#include "io/table.hpp"
#include "sweep/criterion.hpp"
#include "sweep/fit_slices.hpp"
#include "sweep/map_choice.hpp"
#include "sweep/slice_source.hpp"

namespace bsdfmix {

std::vector<KTimingRow> time_k(const std::string& table_path, const FitSettings& fit, const std::string& device_selector,
                               const std::vector<std::size_t>& slices, const std::vector<std::string>& types,
                               const EngineOptions& engine) {
  TableReader reader(table_path);
  const TableMeta& meta = reader.meta();
  const TableSlices source(reader);
  const std::vector<Device> devices = select_devices(device_selector);
  const std::vector<int> ks = candidate_ks(fit.k_min, fit.k_max);
  std::vector<KTimingRow> rows;
  Progress progress("time K on " + table_path, slices.size() * ks.size(), "fits");
  const bool quiet = !Progress::enabled();
  // The kernels are built for each K bucket (the power of two >= K, at least 4) at their
  // first use: one untimed fit per bucket first, so that no build falls inside a timing.
  if (!slices.empty()) {
    Progress::set_enabled(false);
    const std::size_t s = slices.front();
    int warmed = 0;
    for (int k : ks) {
      int bucket = 4;
      while (bucket < k) bucket *= 2;
      if (bucket <= warmed) continue;
      warmed = bucket;
      FitSettings pinned = fit;
      pinned.k_min = pinned.k_max = k;
      pinned.map = map_without_probe(fit, meta.domain);  // a timing: no probe
      fit_slices(source, {SliceRef{s, s / meta.phi_o.size(), s % meta.phi_o.size()}}, pinned, devices, "warm K", engine);
    }
    Progress::set_enabled(!quiet);
  }
  for (std::size_t i = 0; i < slices.size(); ++i) {
    const std::size_t s = slices[i];
    const std::size_t t_o = s / meta.phi_o.size(), p_o = s % meta.phi_o.size();
    for (int k : ks) {
      // The sweep's own fit of this slice with K pinned: what the search's final fits do
      // at that K (k-means++ and split-and-merge, final restarts and iterations, the L1
      // refinement when `refine: l1`).
      FitSettings pinned = fit;
      pinned.k_min = pinned.k_max = k;
      pinned.map = map_without_probe(fit, meta.domain);  // a timing: no probe
      Progress::set_enabled(false);
      const auto t0 = std::chrono::steady_clock::now();
      const SweepResult r = fit_slices(source, {SliceRef{s, t_o, p_o}}, pinned, devices, "time K", engine);
      const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      Progress::set_enabled(!quiet);
      KTimingRow row;
      row.seconds = seconds;
      row.slice = s;
      row.type = i < types.size() ? types[i] : "slice";
      row.theta_o = meta.theta_o[t_o];
      row.k = k;
      row.iterations = r.report.front().iterations;
      row.l1_rel = r.report.front().failed() ? 2.0 : r.report.front().l1_rel;
      rows.push_back(row);
      progress.advance();
    }
  }
  progress.finish();
  return rows;
}

void write_k_timing_csv(const std::string& path, const std::vector<KTimingRow>& rows) {
  std::ostringstream s;
  s << "slice,type,theta_o,k,seconds,iterations,l1_rel\n";
  char buf[256];
  for (const auto& r : rows) {
    std::snprintf(buf, sizeof buf, "%zu,%s,%.9g,%d,%.6f,%d,%.9g\n", r.slice, r.type.c_str(), r.theta_o, r.k, r.seconds,
                  r.iterations, r.l1_rel);
    s << buf;
  }
  write_text_atomic(path, s.str());
}

}  // namespace bsdfmix
