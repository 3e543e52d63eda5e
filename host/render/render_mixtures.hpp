// The mixtures a render uses: the theta_o slices its camera sees (a pre-pass), fitted by
// the sweep, only those, and kept in the config's fit output so that a second render of
// the same scene reuses them.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "fit/em.hpp"
#include "io/mixture_file.hpp"
#include "io/table.hpp"
#include "render/integrator.hpp"
#include "sweep/fit_settings.hpp"

namespace bsdfmix {
namespace render {

// The theta_o slice indices of the table the scene needs: both grid neighbours of the
// theta_o of every fiber hit of a small render (collect_theta_o), sorted, unique.
// InputError naming `where` when no fiber is visible.
std::vector<std::size_t> slices_needed(const SceneView& prepass, const TableMeta& meta, const std::string& where);

// The mixtures of `need` (theta_o slice indices of `table`, a reader of the table in
// memory): the sweep's fit_slices_kept, read from fit.output when it holds those slices of
// this table fitted with these settings, else fitted on `device_selector` (the engine run
// as `engine` says) and written there with the fit report and search CSVs.
MixtureFile render_mixtures(const TableReader& table, const FitSettings& fit, const std::vector<std::size_t>& need,
                            const std::string& device_selector, const EngineOptions& engine = {});

}  // namespace render
}  // namespace bsdfmix
