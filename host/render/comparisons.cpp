// The estimators at equal samples and equal time, and the stand-in against the table.
#include "render/comparisons.hpp"

#include <cmath>
#include <map>
#include <memory>
#include <tuple>

#include "core/format.hpp"
#include "core/progress.hpp"
#include "render/converged_image.hpp"

namespace bsdfmix {
namespace render {

namespace {

double rays_per_second(const RenderStats& st) { return double(st.rays) / std::max(st.seconds, 1e-9); }

// Renders passes of one estimator and f: `spp` of them, or (budget > 0) as many as fit in
// `budget` seconds. With `progress`, the error against the reference after 1, 2, 4, ... passes.
class PassRunner {
 public:
  PassRunner(const SceneView& view, const Image& reference, const GuideSetup& guide)
      : view_(view), reference_(reference), guide_(guide), mask_(material_mask(view)) {}

  // The relative MSE over the whole image and over the material's pixels.
  std::pair<double, double> errors(const Image& im) const {
    return {relative_mse(im, reference_), relative_mse(im, reference_, &mask_)};
  }

  std::pair<Image, RenderStats> run(PathEstimator e, FSource f, int spp, double budget, const std::string& what,
                                    std::vector<RenderRow>* progress) {
    std::vector<double> sum;
    // with a time budget, the passes it should hold (for the progress line's ETA)
    const auto known = pass_seconds_.find(path_estimator_name(e));
    const int expect = budget > 0 && known != pass_seconds_.end() && known->second > 0
                           ? std::max(1, int(std::lround(budget / known->second)))
                           : spp;
    Progress prog("render " + what, std::uint64_t(std::max(expect, 1)), "spp");
    // a guided estimator learns in its own first passes
    std::unique_ptr<GuideTrainer> trainer;
    if (is_guided(e)) trainer = std::make_unique<GuideTrainer>(view_, guide_, what);
    const SceneView& view = trainer ? trainer->view() : view_;
    const RenderStats st = render_passes(view, e, f, 0, budget > 0 ? 1 << 20 : spp, sum, [&](int done, double sec) {
      if (trainer) trainer->after_pass(done);
      prog.advance();
      if (progress && (done & (done - 1)) == 0 && !reference_.v.empty()) {
        RenderRow r;
        r.estimator = path_estimator_name(e);
        r.mode = "progress";
        r.spp = done;
        r.seconds = sec;
        std::tie(r.rel_mse, r.rel_mse_material) = errors(mean_image(sum, done, view_.width, view_.height));
        progress->push_back(r);
      }
      return budget > 0 ? sec < budget : true;
    });
    prog.finish();
    log_line("render: " + what + ": " + std::to_string(st.spp) + " spp in " + format_number(st.seconds, "%.1f") + " s, " +
             format_number(rays_per_second(st) / 1e6, "%.2f") + " M rays/s, " + format_number(st.ns_per_vertex(), "%.0f") +
             " ns per vertex");
    return {mean_image(sum, st.spp, view_.width, view_.height), st};
  }

  // Seconds per pass of an estimator at equal samples (for the ETA of its equal-time render).
  void record(PathEstimator e, const RenderStats& st) {
    pass_seconds_[path_estimator_name(e)] = st.seconds / std::max(st.spp, 1);
  }

 private:
  const SceneView& view_;
  const Image& reference_;
  const GuideSetup& guide_;
  std::map<std::string, double> pass_seconds_;
  const std::vector<std::uint8_t> mask_;
};

}  // namespace

double image_difference(const Image& a, const Image& b, int block) {
  double d = 0, t = 0;
  for (int y0 = 0; y0 + block <= a.height; y0 += block)
    for (int x0 = 0; x0 + block <= a.width; x0 += block) {
      for (int c = 0; c < 3; ++c) {
        double sa = 0, sb = 0;
        for (int y = y0; y < y0 + block; ++y)
          for (int x = x0; x < x0 + block; ++x) {
            sa += a.at(x, y, c);
            sb += b.at(x, y, c);
          }
        d += std::abs(sa - sb);
        t += std::abs(sb);
      }
    }
  return t > 0 ? d / t : 0;
}

Comparisons run_comparisons(const SceneView& view, const RenderSettings& s, const Image& reference,
                            const GuideSetup& guide) {
  Comparisons out;
  PassRunner passes(view, reference, guide);
  // Every estimator at equal samples, then at equal time.
  double budget = s.seconds, slowest = 0;
  for (const PathEstimator e : s.estimators) {
    const std::string name = path_estimator_name(e);
    std::vector<RenderRow> prog;
    auto [im, st] = passes.run(e, FSource::Table, s.spp, 0, name + " (" + std::to_string(s.spp) + " spp)", &prog);
    save_image(s.output, name + "_spp", im);
    passes.record(e, st);
    for (RenderRow& pr : prog) {
      pr.rays_per_second = rays_per_second(st);
      pr.ns_per_vertex = st.ns_per_vertex();
    }
    const auto [all, material] = passes.errors(im);
    out.rows.push_back({name, "equal_spp", name + "_spp.exr", st.spp, st.seconds, rays_per_second(st), all,
                        st.ns_per_vertex(), material});
    out.rows.insert(out.rows.end(), prog.begin(), prog.end());
    slowest = std::max(slowest, st.seconds);
  }
  if (!(budget > 0)) budget = slowest;  // every estimator gets at least spp samples
  out.equal_time_seconds = budget;
  for (const PathEstimator e : s.estimators) {
    const std::string name = path_estimator_name(e);
    auto [im, st] = passes.run(e, FSource::Table, 0, budget, name + " (" + format_number(budget, "%.1f") + " s)", nullptr);
    save_image(s.output, name + "_time", im);
    const auto [all, material] = passes.errors(im);
    out.rows.push_back({name, "equal_time", name + "_time.exr", st.spp, st.seconds, rays_per_second(st), all,
                        st.ns_per_vertex(), material});
  }

  // The stand-in against the table: the same estimator, seed and samples.
  if (!s.stand_in) return out;
  const std::string se = path_estimator_name(s.stand_in_estimator);
  auto [a, sa] = passes.run(s.stand_in_estimator, FSource::Table, s.stand_in_spp, 0, "table f (" + se + ")", nullptr);
  auto [b, sb] = passes.run(s.stand_in_estimator, FSource::StandIn, s.stand_in_spp, 0, "stand-in f (" + se + ")", nullptr);
  save_image(s.output, "table", a);
  save_image(s.output, "stand_in", b);
  out.stand_in_difference = image_difference(b, a, 1);
  out.stand_in_difference_4x4 = image_difference(b, a, 4);
  out.table_noise_4x4 = image_difference(a, reference, 4);
  double ma[3] = {0, 0, 0}, mb[3] = {0, 0, 0};
  for (std::size_t i = 0; i < a.v.size(); ++i) {
    ma[i % 3] += a.v[i];
    mb[i % 3] += b.v[i];
  }
  for (int c = 0; c < 3; ++c) out.stand_in_channel_mean[c] = ma[c] > 0 ? mb[c] / ma[c] - 1 : 0;
  const double ya = Rgb(ma[0], ma[1], ma[2]).luminance(), yb = Rgb(mb[0], mb[1], mb[2]).luminance();
  out.stand_in_mean = ya > 0 ? yb / ya - 1 : 0;
  const auto [ea, ma_] = passes.errors(a);
  const auto [eb, mb_] = passes.errors(b);
  out.rows.push_back({se, "table", "table.exr", sa.spp, sa.seconds, rays_per_second(sa), ea, sa.ns_per_vertex(), ma_});
  out.rows.push_back({se, "stand_in", "stand_in.exr", sb.spp, sb.seconds, rays_per_second(sb), eb, sb.ns_per_vertex(), mb_});
  log_line("render: the stand-in image differs from the table image by " + format_number(100 * out.stand_in_difference, "%.2f") +
           " % per pixel, " + format_number(100 * out.stand_in_difference_4x4, "%.2f") +
           " % over 4 x 4 blocks (the table image's own noise against the reference there: " +
           format_number(100 * out.table_noise_4x4, "%.2f") + " %); image means " + format_number(100 * out.stand_in_mean, "%+.2f") + " % (luminance; R " +
           format_number(100 * out.stand_in_channel_mean[0], "%+.2f") + " %, G " +
           format_number(100 * out.stand_in_channel_mean[1], "%+.2f") + " %, B " +
           format_number(100 * out.stand_in_channel_mean[2], "%+.2f") + " %)");
  return out;
}

}  // namespace render
}  // namespace bsdfmix
