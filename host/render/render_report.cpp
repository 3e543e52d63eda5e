// render.csv and render.json.
#include "render/render_report.hpp"

#include <sstream>

#include "core/atomic_file.hpp"
#include "core/format.hpp"
#include "core/progress.hpp"

namespace bsdfmix {
namespace render {

namespace {

std::string num(double x, const char* f = "%.6g") { return format_number(x, f); }

}  // namespace

void write_render_report(const std::string& csv, const std::string& json, const RenderSettings& s,
                         const RenderFacts& facts, const Comparisons& c) {
  RenderRow ref;
  ref.estimator = path_estimator_name(s.reference_estimator);
  ref.mode = "reference";
  ref.spp = s.reference_spp;
  ref.image = "reference.exr";
  std::string text = "scene,fiber,estimator,mode,spp,seconds,rays_per_second,rel_mse,image,ns_per_vertex,rel_mse_material\n";
  auto add = [&](const RenderRow& r) {
    text += facts.scene + "," + facts.fiber + "," + r.estimator + "," + r.mode + "," + std::to_string(r.spp) + "," +
            num(r.seconds) + "," + num(r.rays_per_second) + "," + (r.rel_mse >= 0 ? num(r.rel_mse) : "") + "," +
            r.image + "," + (r.ns_per_vertex > 0 ? num(r.ns_per_vertex, "%.0f") : "") + "," +
            (r.rel_mse_material >= 0 ? num(r.rel_mse_material) : "") + "\n";
  };
  add(ref);
  for (const RenderRow& r : c.rows) add(r);
  write_text_atomic(csv, text);
  std::ostringstream js;
  js << "{\"scene\": \"" << facts.scene << "\", \"fiber\": \"" << facts.fiber << "\", \"width\": " << s.width
     << ", \"height\": " << s.height << ", \"table_bytes\": " << facts.table_bytes
     << ", \"mixture_bytes\": " << facts.mixture_bytes << ", \"full_table_bytes\": " << facts.full_table_bytes
     << ", \"slices_needed\": " << facts.slices_needed << ", \"slices_total\": " << facts.slices_total
     << ", \"equal_time_seconds\": " << num(c.equal_time_seconds)
     << ", \"reference\": \"reference.exr\", \"stand_in_difference\": " << num(c.stand_in_difference)
     << ", \"stand_in_difference_4x4\": " << num(c.stand_in_difference_4x4)
     << ", \"table_noise_4x4\": " << num(c.table_noise_4x4) << ", \"stand_in_mean_difference\": " << num(c.stand_in_mean)
     << ", \"stand_in_channel_mean_difference\": [" << num(c.stand_in_channel_mean[0]) << ", "
     << num(c.stand_in_channel_mean[1]) << ", " << num(c.stand_in_channel_mean[2]) << "]"
     << ", \"fibers\": " << facts.fibers << ", \"segments\": " << facts.segments << "}\n";
  write_text_atomic(json, js.str());
  const double mixture = double(std::max<std::uint64_t>(facts.mixture_bytes, 1));
  log_line("render: wrote " + csv + " and " + json + "; table " + num(double(facts.table_bytes) / 1048576.0, "%.1f") +
           " MiB, mixtures " + num(double(facts.mixture_bytes) / 1024.0, "%.1f") + " KiB (" +
           num(double(facts.table_bytes) / mixture, "%.0f") + "x less; " +
           num(double(facts.full_table_bytes) / mixture, "%.0f") + "x less than the full 4D table)");
}

}  // namespace render
}  // namespace bsdfmix
