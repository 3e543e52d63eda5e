// The mixtures a render uses: the slices it needs, fitted once and kept by the sweep.
#include "render/render_mixtures.hpp"

#include <set>

#include "core/error.hpp"
#include "core/progress.hpp"
#include "sweep/fit_slices.hpp"
#include "sweep/slice_source.hpp"

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

MixtureFile render_mixtures(const TableReader& table, const FitSettings& fit, const std::vector<std::size_t>& need,
                            const std::string& device_selector, const EngineOptions& engine) {
  std::vector<SliceRef> slices;  // the renderer's tables are azimuthal: one phi_o
  for (std::size_t i : need) slices.push_back({table.meta().slice_index(i, 0), i, 0});
  return fit_slices_kept(TableSlices(table), table.path(), slices, fit, device_selector, "render", engine);
}

}  // namespace render
}  // namespace bsdfmix
