// `fit.map: auto` (docs/fitting.md, "The map"): the map a fit takes when its settings leave
// the choice to it. On the fiber sphere, (theta, phi): the cylinder fitted every preset
// worse (bench/results/map_accuracy.csv). On the hemisphere, a probe: a few of the planned
// slices, spread over theta_o, fitted in both maps with the fit's own settings; the disk
// is taken unless its median relative L1 there exceeds (theta, phi)'s by kProbeMargin, for
// its density per steradian is bounded (docs/sampling.md, "A renderer's sampling test").
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "device/device.hpp"
#include "fit/em.hpp"
#include "sweep/fit_settings.hpp"
#include "sweep/fit_slices.hpp"
#include "sweep/slice_plan.hpp"
#include "sweep/slice_source.hpp"

namespace bsdfmix {

// Slices the probe fits in both maps; a plan of this many or fewer is probed whole.
constexpr std::size_t kProbeSlices = 10;
// How much more median relative L1 the disk may have on the probe and still be chosen.
constexpr double kProbeMargin = 0.003;

struct MapChoice {
  std::string map;           // "theta_phi" or "equal_area": the map fitted
  std::size_t probed = 0;    // slices fitted in both maps (0: no probe)
  double l1_theta_phi = 0;   // the probe's median relative L1 in (theta, phi)
  double l1_equal_area = 0;  // and in the equal-area map
  double seconds = 0;        // the probe's wall time
  // The chosen map's fits of the whole plan, when the probe covered it.
  std::optional<SweepResult> whole;
  // The summary's line ("" without a probe): the map and the probe's two errors.
  std::string text() const;
};

// Whether settings leave the map to the fit on domain d (auto on the hemisphere).
bool map_probed(const FitSettings& fit, Domain d);

// The map of settings that need no probe: theta_phi or equal_area as set, and auto on the
// fiber sphere as (theta, phi). auto on the hemisphere gives the disk: for fits whose
// map does not matter (timings).
std::string map_without_probe(const FitSettings& fit, Domain d);

// The probe's slices: kProbeSlices of the plan, evenly spread, the first and last included.
std::vector<SliceRef> probe_slices(const std::vector<SliceRef>& plan);

// The map for fitting `plan`: map_without_probe when map_probed is false, else the probe's
// choice. `what` labels the probe's progress lines.
MapChoice choose_map(const SliceSource& source, const std::vector<SliceRef>& plan, const FitSettings& fit,
                     const std::vector<Device>& devices, const EngineOptions& engine, const std::string& what);

// The fit.map setting that fits in plane m: theta_phi, or equal_area for the disk and the
// cylinder (a lighting fitted for a product with a mixture of that plane, say).
std::string map_setting(Map m);

// `fit` with `map` in force (the fits use it; the file records the settings as given).
FitSettings with_map(FitSettings fit, const std::string& map);

// The choice as kept beside a file sweep's output, so a resumed fit takes it again
// without probing: `key` identifies the table, plan and settings (sweep_fingerprint).
std::string map_choice_record(const MapChoice& c, const std::string& key);
std::optional<MapChoice> read_map_choice(const std::string& record, const std::string& key);

}  // namespace bsdfmix
