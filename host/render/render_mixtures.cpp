// The mixtures a render uses: the slices it needs, fitted once and kept.
#include "render/render_mixtures.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <set>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "core/output_lock.hpp"
#include "core/progress.hpp"
#include "device/device.hpp"
#include "sweep/fit_slices.hpp"
#include "sweep/sweep_outputs.hpp"

namespace bsdfmix {
namespace render {

std::vector<std::size_t> slices_needed(const SceneView& prepass, const TableMeta& meta, const std::string& where) {
  const std::vector<double> thetas = collect_theta_o(prepass, 2);
  std::set<std::size_t> need;
  for (const double t : thetas) {
    const Bracket b = bracket(meta.theta_o, t, false);
    need.insert(b.i0);
    if (b.f > 0) need.insert(b.i1);
  }
  if (need.empty()) throw InputError(where + ": render: neither fiber nor surface is visible from the camera (check the camera, the cloth or the sphere)");
  log_line("render: the pre-pass (" + std::to_string(prepass.width) + " x " + std::to_string(prepass.height) + ", " +
           std::to_string(thetas.size()) + " hits) needs " + std::to_string(need.size()) + " of " +
           std::to_string(meta.theta_o.size()) + " theta_o slices");
  return {need.begin(), need.end()};
}

MixtureFile render_mixtures(const std::string& table, const FitSection& fit_section,
                            const std::vector<std::size_t>& need, const std::string& device_selector) {
  const TableReader reader(table);
  const TableMeta& meta = reader.meta();
  const FitSection& fit = fit_section;
  std::vector<SliceRef> slices;  // the renderer's tables are azimuthal: one phi_o
  std::vector<double> thetas;
  for (std::size_t i : need) {
    slices.push_back({meta.slice_index(i, 0), i, 0});
    thetas.push_back(meta.theta_o[i]);
  }
  const OutputLock lock(fit.output);  // a fit of the same output elsewhere fails here, at once
  if (std::filesystem::exists(fit.output)) {
    // Reused when it holds the slices needed (the sweep stores their grid theta_o), fitted
    // to this table with these settings: as it is when it holds exactly those, else those
    // slices taken out of it (a sweep of every slice serves any render of its table).
    MixtureFile mf = read_mixture_file(fit.output);
    if (mf.table_source == meta.source && mf.fit_settings == fit_settings_json(fit)) {
      if (mf.theta_o == thetas) return mf;
      MixtureFile sub = mf.header_only();
      for (double t : thetas) {
        const auto at = std::find(mf.theta_o.begin(), mf.theta_o.end(), t);
        if (at == mf.theta_o.end()) break;
        sub.add_slice_from(mf, std::size_t(at - mf.theta_o.begin()));
      }
      if (sub.slices() == thetas.size()) {
        log_line("render: the " + std::to_string(thetas.size()) + " slices needed, from " + fit.output);
        return sub;
      }
    }
  }
  for (const auto* out : {&fit.output, &fit.report, &fit.search_report}) prepare_output(*out, 1 << 20);
  const std::vector<Device> devices = select_devices(device_selector);
  log_line("render: fitting " + std::to_string(slices.size()) + " slice(s) of " + table + ", K in [" +
           std::to_string(fit.k_min) + ", " + std::to_string(fit.k_max) + "]");
  SweepResult result = fit_slices(TableSlices(reader), slices, fit, devices, "fit " + table);
  write_outputs(result, table, meta, fit);
  return std::move(result.mixture);
}

}  // namespace render
}  // namespace bsdfmix
