// The render command's stages, in order.
#include "render/render_run.hpp"

#include <algorithm>
#include <filesystem>
#include <memory>
#include <optional>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "core/output_lock.hpp"
#include "core/progress.hpp"
#include "io/table.hpp"
#include "render/comparisons.hpp"
#include "render/light_carry.hpp"
#include "render/converged_image.hpp"
#include "render/full_f.hpp"
#include "render/render_mixtures.hpp"
#include "render/render_report.hpp"
#include "render/render_scene.hpp"
#include "render/world_lighting.hpp"
#include "tables/rgl_brdf.hpp"

namespace bsdfmix {
namespace render {

bool needs_rgl(const RenderSettings& s) {
  return std::any_of(s.estimators.begin(), s.estimators.end(), uses_rgl) || uses_rgl(s.reference_estimator) ||
         (s.stand_in && uses_rgl(s.stand_in_estimator));
}

GuideSetup guide_setup(const RenderSettings& s, const FitSettings& fit, const std::string& device_selector,
                       const EngineOptions& engine) {
  GuideSetup g;
  g.field = s.guide;
  g.iterations = s.guide_iterations;
  g.depth = s.guide_depth;
  // a leaf's grid is small and noisy: the search up to k_max with one restart, EM's fits
  // (no L1 refinement), the config's seed, penalty and search strategy
  FitSettings& f = g.field.fit;
  f = fit;
  f.output = f.report = f.search_report = "";
  f.theta_o.clear();
  f.phi_o.clear();
  f.k_min = 1;
  f.k_max = s.guide_k_max;
  f.restarts = f.final_restarts = 1;
  f.iterations = 40;
  f.final_iterations = 100;
  f.refine = "none";
  f.error_target.reset();
  f.map = "theta_phi";  // the leaves' Gaussians are read as (theta, phi) on the fiber sphere
  g.field.compact_sigma = kBroadSigma;
  const bool guided = std::any_of(s.estimators.begin(), s.estimators.end(), is_guided);
  if (guided) g.devices = select_devices(device_selector);
  g.engine = engine;
  return g;
}

void run_render(const RenderSettings& s, const RenderInputs& in) {
  namespace fs = std::filesystem;
  fs::create_directories(s.output);
  // one render per output directory at a time (a second one fails at once, naming the first)
  const OutputLock lock((fs::path(s.output) / "render").string());
  const std::string csv = (fs::path(s.output) / "render.csv").string();
  const std::string json = (fs::path(s.output) / "render.json").string();
  prepare_output(csv);
  prepare_output(json);

  // The table, read once into memory: the BSDF's cells, the slices the mixtures are
  // fitted to, and the hash in the reference's key. Let go once the mixtures are made.
  std::optional<LoadedTable> table = load_table(in.table);
  const std::uint64_t table_hash = table->file_hash;
  TableBsdf bsdf(table->reader);
  // is_rgl, mis_light_rgl: the file's own sampler (f stays the table's, for every estimator)
  std::unique_ptr<RglBrdf> rgl;
  if (needs_rgl(s)) {
    rgl = std::make_unique<RglBrdf>(in.rgl);
    bsdf.set_rgl(rgl.get());
  }
  // f at fibers from a full-4D table, mapped, and its stand-in (the samplers stay the table's)
  std::unique_ptr<FullF> full;
  if (!s.table_4d.empty()) {
    if (bsdf.meta().domain != Domain::Fiber)
      throw InputError(in.table + ": render.table_4d needs a fiber table as `table` (its samplers draw directions)");
    full = open_full(s.table_4d, s.mixture_4d);
    bsdf.set_full(full.get());
  }
  const RenderScene scene(s, bsdf, s.file);
  log_line("render: " + scene.describe() + ", lighting '" + s.lighting.name + "', " + std::to_string(s.width) + " x " +
           std::to_string(s.height));

  // 1. The slices the camera needs; 2. their mixtures.
  const TableMeta& meta = bsdf.meta();
  const std::vector<std::size_t> need = slices_needed(scene.prepass_view(s), meta, s.file);
  const MixtureFile mixtures = render_mixtures(table->reader, in.fit, need, in.device_selector, in.engine);
  table.reset();
  bsdf.set_mixture(to_mixture_set(mixtures));

  // mis_product's lighting, over world directions
  SceneView view = scene.view();
  std::vector<mix::Gaussian> compact;
  if (needs_world_lighting(s)) {
    compact = world_lighting(s, in.fit, in.device_selector, in.engine);
    view.world_light = &compact;
  }

  // 3. The converged image (cached under its key); 4. the comparisons against it, the
  // guided estimators learning with the leaves' fit settings.
  const Image converged = converged_image(view, s, scene_key(s, in.table, table_hash) + (full ? full->key : ""));
  const GuideSetup guide = guide_setup(s, in.fit, in.device_selector, in.engine);
  const Comparisons comparisons = run_comparisons(view, s, converged, guide);

  // 5. The report and the cloth's pixels (the figures are the command's).
  write_pfm((fs::path(s.output) / "cloth_mask.pfm").string(), scene.cloth_mask());
  RenderFacts facts;
  facts.scene = s.room.enabled ? s.lighting.name + "_room" : s.lighting.name;  // the lighting, through a window
  facts.fiber = fs::path(in.table).stem().string();
  facts.table_bytes = bsdf.table_bytes();
  facts.full_table_bytes = std::uint64_t(bsdf.table_bytes()) * meta.phi_i.size();
  facts.mixture_bytes = mixtures.payload_bytes();
  facts.slices_needed = need.size();
  facts.slices_total = meta.theta_o.size();
  facts.fibers = scene.cloth().fibers.size();
  facts.segments = scene.cloth().segments();
  write_render_report(csv, json, s, facts, comparisons);
  if (full) write_full_report((fs::path(s.output) / "table_4d.csv").string(), *full);
}

}  // namespace render
}  // namespace bsdfmix
