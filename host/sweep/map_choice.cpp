// fit.map auto: the probe that chooses the map, and its record beside a file sweep.
#include "sweep/map_choice.hpp"

#include <chrono>
#include <cmath>
#include <sstream>

#include "core/format.hpp"
#include "core/progress.hpp"
#include "core/stats.hpp"

namespace bsdfmix {

namespace {

// The median relative L1 over the slices fitted well in both maps.
void median_l1(const SweepResult& tp, const SweepResult& ea, double& l1_tp, double& l1_ea) {
  std::vector<double> a, b;
  for (std::size_t i = 0; i < tp.report.size() && i < ea.report.size(); ++i) {
    const ReportRow &x = tp.report[i], &y = ea.report[i];
    if (x.failed() || y.failed() || !std::isfinite(x.l1_rel) || !std::isfinite(y.l1_rel)) continue;
    a.push_back(x.l1_rel);
    b.push_back(y.l1_rel);
  }
  l1_tp = quantile(a, 0.5);
  l1_ea = quantile(b, 0.5);
}

}  // namespace

std::string MapChoice::text() const {
  if (probed == 0) return "";
  const bool disk = map == "equal_area";
  return std::string(disk ? "the equal-area disk" : "(theta, phi)") + ", by a probe of " + std::to_string(probed) +
         " slice(s) in " + format_number(seconds, "%.1f") + " s: median L1 " + format_number(100 * l1_equal_area, "%.2f") +
         "% on the disk, " + format_number(100 * l1_theta_phi, "%.2f") + "% in (theta, phi)";
}

bool map_probed(const FitSettings& fit, Domain d) { return fit.map == "auto" && d == Domain::Hemisphere; }

std::string map_without_probe(const FitSettings& fit, Domain d) {
  if (fit.map != "auto") return fit.map;
  return d == Domain::Hemisphere ? "equal_area" : "theta_phi";
}

std::vector<SliceRef> probe_slices(const std::vector<SliceRef>& plan) {
  if (plan.size() <= kProbeSlices) return plan;
  std::vector<SliceRef> out;
  for (std::size_t i = 0; i < kProbeSlices; ++i)
    out.push_back(plan[i * (plan.size() - 1) / (kProbeSlices - 1)]);
  return out;
}

std::string map_setting(Map m) { return m == Map::ThetaPhi ? "theta_phi" : "equal_area"; }

FitSettings with_map(FitSettings fit, const std::string& map) {
  fit.map = map;
  return fit;
}

MapChoice choose_map(const SliceSource& source, const std::vector<SliceRef>& plan, const FitSettings& fit,
                     const std::vector<Device>& devices, const EngineOptions& engine, const std::string& what) {
  MapChoice c;
  c.map = map_without_probe(fit, source.meta().domain);
  if (!map_probed(fit, source.meta().domain) || plan.empty()) return c;
  const auto start = std::chrono::steady_clock::now();
  const std::vector<SliceRef> probe = probe_slices(plan);
  log_line(what + ": choosing the map (fit.map auto): " + std::to_string(probe.size()) +
           " slice(s) fitted on the disk and in (theta, phi)");
  SweepResult tp = fit_slices(source, probe, with_map(fit, "theta_phi"), devices, what + " probe, (theta, phi)", engine);
  SweepResult ea = fit_slices(source, probe, with_map(fit, "equal_area"), devices, what + " probe, disk", engine);
  c.probed = probe.size();
  c.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  median_l1(tp, ea, c.l1_theta_phi, c.l1_equal_area);
  c.map = c.l1_equal_area <= c.l1_theta_phi + kProbeMargin ? "equal_area" : "theta_phi";
  if (probe.size() == plan.size()) c.whole = std::move(c.map == "equal_area" ? ea : tp);
  log_line(what + ": map " + c.text());
  return c;
}

std::string map_choice_record(const MapChoice& c, const std::string& key) {
  return "bsdfmix map choice\n" + key + "\n" + c.map + " " + std::to_string(c.probed) + " " +
         format_number(c.l1_theta_phi, "%.17g") + " " + format_number(c.l1_equal_area, "%.17g") + " " +
         format_number(c.seconds, "%.3f") + "\n";
}

std::optional<MapChoice> read_map_choice(const std::string& record, const std::string& key) {
  const std::string head = "bsdfmix map choice\n" + key + "\n";
  if (record.compare(0, head.size(), head) != 0) return std::nullopt;
  std::istringstream in(record.substr(head.size()));
  MapChoice c;
  if (!(in >> c.map >> c.probed >> c.l1_theta_phi >> c.l1_equal_area >> c.seconds)) return std::nullopt;
  if (c.map != "theta_phi" && c.map != "equal_area") return std::nullopt;
  return c;
}

}  // namespace bsdfmix
