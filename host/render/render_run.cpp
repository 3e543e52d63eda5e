// The render command's pipeline.
#include "render/render_run.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <fstream>
#include <set>
#include <sstream>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "core/hash.hpp"
#include "core/output_lock.hpp"
#include "core/progress.hpp"
#include "io/mixture_file.hpp"
#include "pipeline/scripts.hpp"
#include "pipeline/stages.hpp"
#include "render/integrator.hpp"
#include "sweep/sweep.hpp"

namespace bsdfmix {
namespace render {

namespace {

std::string num(double x, const char* f = "%.6g") {
  char b[64];
  std::snprintf(b, sizeof b, f, x);
  return b;
}

Image to_image(const std::vector<double>& sum, int spp, int w, int h) {
  Image im(w, h);
  for (std::size_t i = 0; i < im.v.size(); ++i) im.v[i] = float(sum[i] / std::max(spp, 1));
  return im;
}

void save(const std::string& dir, const std::string& stem, const Image& im) {
  write_exr((std::filesystem::path(dir) / (stem + ".exr")).string(), im);
  write_pfm((std::filesystem::path(dir) / (stem + ".pfm")).string(), im);
}

// Everything a render's pixels depend on but the estimator and the sample count.
std::string scene_key(const RenderSettings& s, const std::string& table, const Config& config) {
  std::ostringstream k;
  k << "table " << table << " " << hex64(hash_file(table)) << "\nsize " << s.width << "x" << s.height << "\ndepth "
    << s.max_depth << " " << s.rr_depth << "\nseed " << s.seed << "\ncamera";
  for (int i = 0; i < 3; ++i) k << " " << s.camera.position[i] << " " << s.camera.look_at[i] << " " << s.camera.up[i];
  k << " " << s.camera.fov_deg << "\ncloth " << s.cloth.weave << " " << s.cloth.size << " " << s.cloth.yarn_spacing << " "
    << s.cloth.yarn_radius << " " << s.cloth.plies << " " << s.cloth.ply_twist << " " << s.cloth.fibers_per_ply << " "
    << s.cloth.fiber_twist << " " << s.cloth.fiber_radius << " " << s.cloth.jitter << " " << s.cloth.segments_per_spacing
    << " " << s.cloth.seed << " " << s.cloth.drape << " " << s.cloth.drape_radius << "\nground " << s.ground.enabled << " "
    << s.ground.z << " " << s.ground_albedo << "\nlight";
  for (float x : s.lighting.pack()) k << " " << x;
  Hash64 h;
  h.update(s.lighting.env.data(), s.lighting.env.size() * sizeof(float));
  k << " env " << h.hex() << "\nreference " << path_estimator_name(s.reference_estimator) << " " << s.reference_spp
    << "\nversion " << BSDFMIX_VERSION << "\n";
  (void)config;
  return k.str();
}

// sum |a - b| / sum |b| over blocks of `block` x `block` pixels (averaged): the mean
// relative difference of two images, with the Monte Carlo noise of both reduced by the blocks.
double image_difference(const Image& a, const Image& b, int block) {
  double d = 0, t = 0;
  for (int y0 = 0; y0 + block <= a.height; y0 += block)
    for (int x0 = 0; x0 + block <= a.width; x0 += block) {
      double sa = 0, sb = 0;
      for (int y = y0; y < y0 + block; ++y)
        for (int x = x0; x < x0 + block; ++x) {
          sa += a.at(x, y);
          sb += b.at(x, y);
        }
      d += std::abs(sa - sb);
      t += std::abs(sb);
    }
  return t > 0 ? d / t : 0;
}

struct Row {
  std::string estimator, mode, image;
  int spp = 0;
  double seconds = 0, rays_per_second = 0, rel_mse = -1;
};

}  // namespace

void run_render(const Config& config, const std::string& device_selector, bool figures) {
  if (!config.render) throw ConfigError(config.file + ": render: missing (the render command needs a render section)");
  if (!config.fit) throw ConfigError(config.file + ": fit: missing (the render fits the mixtures the scene needs)");
  const RenderSettings s = parse_render(*config.render);
  const std::string dev = device_for(config, device_selector);
  stage_table(config, dev);
  std::filesystem::create_directories(s.output);
  // one render per output directory at a time (a second one fails at once, naming the first)
  const OutputLock lock((std::filesystem::path(s.output) / "render").string());
  const std::string csv = (std::filesystem::path(s.output) / "render.csv").string();
  const std::string json = (std::filesystem::path(s.output) / "render.json").string();
  prepare_output(csv);
  prepare_output(json);

  FiberBsdf bsdf(config.table);
  const Cloth cloth = make_cloth(s.cloth, config.file + ": render.cloth");
  GroundPlane ground = s.ground;
  ground.half = 4 * std::max(s.cloth.size, 1.0);
  const Tracer tracer(cloth, ground);
  const LightSampler light = make_light_sampler(s.lighting);
  SceneView view;
  view.tracer = &tracer;
  view.bsdf = &bsdf;
  view.lighting = &s.lighting;
  view.light = &light;
  view.camera = s.camera;
  view.ground_albedo = s.ground_albedo;
  view.fiber_radius = s.cloth.fiber_radius;
  view.max_depth = s.max_depth;
  view.rr_depth = s.rr_depth;
  view.threads = s.threads;
  view.seed = s.seed;
  log_line("render: " + std::to_string(cloth.fibers.size()) + " fibers, " + std::to_string(cloth.segments()) +
           " segments, lighting '" + s.lighting.name + "', " + std::to_string(s.width) + " x " +
           std::to_string(s.height));

  // 1. The pre-pass: which theta_o slices the scene needs (both neighbours of every hit).
  SceneView pre = view;
  pre.width = pre.height = s.prepass;
  pre.max_depth = std::min(s.max_depth, s.prepass_depth);
  const std::vector<double> thetas = collect_theta_o(pre, 2);
  const TableMeta& meta = bsdf.meta();
  std::set<std::size_t> need;
  const double dto = meta.theta_o.size() > 1 ? axis_step(meta.theta_o) : 1.0;
  for (const double t : thetas) {
    const double u = std::clamp((t - meta.theta_o.front()) / dto, 0.0, double(meta.theta_o.size() - 1));
    need.insert(std::size_t(std::floor(u)));
    need.insert(std::min(std::size_t(std::ceil(u)), meta.theta_o.size() - 1));
  }
  if (need.empty()) throw InputError(config.file + ": render: no fiber is visible from the camera (check camera and cloth)");
  log_line("render: the pre-pass (" + std::to_string(s.prepass) + " x " + std::to_string(s.prepass) + ", " +
           std::to_string(thetas.size()) + " fiber hits) needs " + std::to_string(need.size()) + " of " +
           std::to_string(meta.theta_o.size()) + " theta_o slices");

  // 2. The mixtures of those slices (fitted unless the file already holds exactly them).
  FitSection fit = *config.fit;
  fit.theta_o.clear();
  for (std::size_t i : need) fit.theta_o.push_back(meta.theta_o[i]);
  bool fitted = false;
  if (std::filesystem::exists(fit.output)) {
    const MixtureFile mf = read_mixture_file(fit.output);
    std::set<std::size_t> have;
    for (double t : mf.theta_o) {
      const double u = (t - meta.theta_o.front()) / dto;
      have.insert(std::size_t(std::llround(u)));
    }
    fitted = have == need;
  }
  if (!fitted) run_sweep(config.table, fit, dev);
  const MixtureFile mf = read_mixture_file(fit.output);
  bsdf.set_mixture(to_mixture_set(mf));

  // 3. The reference (cached under its key).
  const std::string key = scene_key(s, config.table, config);
  const std::string key_path = (std::filesystem::path(s.output) / "reference.key").string();
  const std::string ref_pfm = (std::filesystem::path(s.output) / "reference.pfm").string();
  Image reference;
  {
    std::string old;
    if (std::filesystem::exists(key_path) && std::filesystem::exists(ref_pfm)) {
      std::ifstream in(key_path);
      std::stringstream ss;
      ss << in.rdbuf();
      old = ss.str();
    }
    if (old == key) {
      reference = read_pfm_image(ref_pfm);
      log_line("render: reference read from " + ref_pfm);
    }
  }
  std::vector<Row> rows;
  std::map<std::string, double> pass_seconds;  // per estimator: seconds per pass at equal samples
  auto passes = [&](PathEstimator e, FiberF f, int spp, double budget, const std::string& what,
                    std::vector<Row>* progress_rows) {
    std::vector<double> sum;
    // with a time budget, the passes it should hold (for the progress line's ETA)
    const auto known = pass_seconds.find(path_estimator_name(e));
    const int expect = budget > 0 && known != pass_seconds.end() && known->second > 0
                           ? std::max(1, int(std::lround(budget / known->second)))
                           : spp;
    Progress prog("render " + what, std::uint64_t(std::max(expect, 1)), "spp");
    RenderStats st = render_passes(view, e, f, 0, budget > 0 ? 1 << 20 : spp, sum, [&](int done, double sec) {
      prog.advance();
      if (progress_rows && (done & (done - 1)) == 0 && !reference.v.empty()) {
        Row r;
        r.estimator = path_estimator_name(e);
        r.mode = "progress";
        r.spp = done;
        r.seconds = sec;
        r.rel_mse = relative_mse(to_image(sum, done, s.width, s.height), reference);
        progress_rows->push_back(r);
      }
      return budget > 0 ? sec < budget : true;
    });
    prog.finish();
    log_line("render: " + what + ": " + std::to_string(st.spp) + " spp in " + num(st.seconds, "%.1f") + " s, " +
             num(double(st.rays) / std::max(st.seconds, 1e-9) / 1e6, "%.2f") + " M rays/s");
    return std::make_pair(to_image(sum, st.spp, s.width, s.height), st);
  };
  view.width = s.width;
  view.height = s.height;
  if (reference.v.empty()) {
    // The reference is the long part: its sums are checkpointed every 1/16 of it, and a killed
    // run resumes from the last checkpoint of the same key (pass i always draws the same
    // numbers, so the result is the same as an uninterrupted run's).
    const std::string ckpt = (std::filesystem::path(s.output) / "reference.partial").string();
    std::vector<double> sum;
    int done = 0;
    {
      std::ifstream in(ckpt, std::ios::binary);
      std::string head;
      if (in && std::getline(in, head) && head == Hash64().update(key.data(), key.size()).hex()) {
        in.read(reinterpret_cast<char*>(&done), sizeof done);
        sum.resize(std::size_t(s.width) * std::size_t(s.height));
        in.read(reinterpret_cast<char*>(sum.data()), std::streamsize(sum.size() * sizeof(double)));
        if (!in || done < 0 || done > s.reference_spp) {
          sum.clear();
          done = 0;
        } else {
          log_line("render: the reference resumes at " + std::to_string(done) + " of " +
                   std::to_string(s.reference_spp) + " spp (" + ckpt + ")");
        }
      }
    }
    Progress prog("render reference", std::uint64_t(s.reference_spp), "spp");
    prog.advance(std::uint64_t(done));
    const int every = std::max(1, s.reference_spp / 16);
    const RenderStats st =
        render_passes(view, s.reference_estimator, FiberF::Table, done, s.reference_spp - done, sum, [&](int n, double) {
          prog.advance();
          if ((done + n) % every == 0 && done + n < s.reference_spp) {
            std::string blob = Hash64().update(key.data(), key.size()).hex() + "\n";
            const int at = done + n;
            blob.append(reinterpret_cast<const char*>(&at), sizeof at);
            blob.append(reinterpret_cast<const char*>(sum.data()), sum.size() * sizeof(double));
            write_text_atomic(ckpt, blob);
          }
          return true;
        });
    prog.finish();
    log_line("render: reference: " + std::to_string(s.reference_spp) + " spp (" + std::to_string(st.spp) + " in " +
             num(st.seconds, "%.1f") + " s, " + num(double(st.rays) / std::max(st.seconds, 1e-9) / 1e6, "%.2f") +
             " M rays/s)");
    reference = to_image(sum, s.reference_spp, s.width, s.height);
    save(s.output, "reference", reference);
    write_text_atomic(key_path, key);
    std::filesystem::remove(ckpt);
  }
  {
    Row r;
    r.estimator = path_estimator_name(s.reference_estimator);
    r.mode = "reference";
    r.spp = s.reference_spp;
    r.image = "reference.exr";
    rows.push_back(r);
  }

  // 4. Every estimator at equal samples, then at equal time.
  double budget = s.seconds, slowest = 0;
  for (const PathEstimator e : s.estimators) {
    const std::string name = path_estimator_name(e);
    std::vector<Row> prog;
    auto [im, st] = passes(e, FiberF::Table, s.spp, 0, name + " (" + std::to_string(s.spp) + " spp)", &prog);
    save(s.output, name + "_spp", im);
    pass_seconds[name] = st.seconds / std::max(st.spp, 1);
    for (Row& pr : prog) pr.rays_per_second = double(st.rays) / std::max(st.seconds, 1e-9);
    Row r{name, "equal_spp", name + "_spp.exr", st.spp, st.seconds, double(st.rays) / std::max(st.seconds, 1e-9),
          relative_mse(im, reference)};
    rows.push_back(r);
    rows.insert(rows.end(), prog.begin(), prog.end());
    slowest = std::max(slowest, st.seconds);
  }
  if (!(budget > 0)) budget = slowest;  // every estimator gets at least spp samples
  for (const PathEstimator e : s.estimators) {
    const std::string name = path_estimator_name(e);
    auto [im, st] = passes(e, FiberF::Table, 0, budget, name + " (" + num(budget, "%.1f") + " s)", nullptr);
    save(s.output, name + "_time", im);
    rows.push_back({name, "equal_time", name + "_time.exr", st.spp, st.seconds,
                    double(st.rays) / std::max(st.seconds, 1e-9), relative_mse(im, reference)});
  }

  // 5. The stand-in against the table: the same estimator, seed and samples.
  double stand_in_diff = -1, stand_in_diff4 = -1, table_noise4 = -1, stand_in_mean = 0;
  if (s.stand_in) {
    const std::string se = path_estimator_name(s.stand_in_estimator);
    auto [a, sa] = passes(s.stand_in_estimator, FiberF::Table, s.stand_in_spp, 0, "table f (" + se + ")", nullptr);
    auto [b, sb] = passes(s.stand_in_estimator, FiberF::StandIn, s.stand_in_spp, 0, "stand-in f (" + se + ")", nullptr);
    save(s.output, "table", a);
    save(s.output, "stand_in", b);
    stand_in_diff = image_difference(b, a, 1);
    stand_in_diff4 = image_difference(b, a, 4);
    table_noise4 = image_difference(a, reference, 4);
    double ma = 0, mb = 0;
    for (std::size_t i = 0; i < a.v.size(); ++i) {
      ma += a.v[i];
      mb += b.v[i];
    }
    stand_in_mean = ma > 0 ? mb / ma - 1 : 0;
    rows.push_back({se, "table", "table.exr", sa.spp, sa.seconds, double(sa.rays) / std::max(sa.seconds, 1e-9),
                    relative_mse(a, reference)});
    rows.push_back({se, "stand_in", "stand_in.exr", sb.spp, sb.seconds,
                    double(sb.rays) / std::max(sb.seconds, 1e-9), relative_mse(b, reference)});
    log_line("render: the stand-in image differs from the table image by " + num(100 * stand_in_diff, "%.2f") +
             " % per pixel, " + num(100 * stand_in_diff4, "%.2f") + " % over 4 x 4 blocks (the table image's own noise "
             "against the reference there: " + num(100 * table_noise4, "%.2f") + " %); image means " +
             num(100 * stand_in_mean, "%+.2f") + " %");
  }

  // 6. The CSV, the JSON and the figures.
  const std::string scene = s.lighting.name, fiber = std::filesystem::path(config.table).stem().string();
  std::string text = "scene,fiber,estimator,mode,spp,seconds,rays_per_second,rel_mse,image\n";
  for (const Row& r : rows)
    text += scene + "," + fiber + "," + r.estimator + "," + r.mode + "," + std::to_string(r.spp) + "," +
            num(r.seconds) + "," + num(r.rays_per_second) + "," + (r.rel_mse >= 0 ? num(r.rel_mse) : "") + "," +
            r.image + "\n";
  write_text_atomic(csv, text);
  const std::uint64_t full = std::uint64_t(bsdf.table_bytes()) * meta.phi_i.size();
  std::ostringstream js;
  js << "{\"scene\": \"" << scene << "\", \"fiber\": \"" << fiber << "\", \"width\": " << s.width
     << ", \"height\": " << s.height << ", \"table_bytes\": " << bsdf.table_bytes()
     << ", \"mixture_bytes\": " << mf.payload_bytes() << ", \"full_table_bytes\": " << full
     << ", \"slices_needed\": " << need.size() << ", \"slices_total\": " << meta.theta_o.size()
     << ", \"equal_time_seconds\": " << num(budget) << ", \"reference\": \"reference.exr\", \"stand_in_difference\": "
     << num(stand_in_diff) << ", \"stand_in_difference_4x4\": " << num(stand_in_diff4)
     << ", \"table_noise_4x4\": " << num(table_noise4) << ", \"stand_in_mean_difference\": " << num(stand_in_mean)
     << ", \"fibers\": " << cloth.fibers.size() << ", \"segments\": " << cloth.segments() << "}\n";
  write_text_atomic(json, js.str());
  log_line("render: wrote " + csv + " and " + json + "; table " + num(bsdf.table_bytes() / 1048576.0, "%.1f") +
           " MiB, mixtures " + num(mf.payload_bytes() / 1024.0, "%.1f") + " KiB (" +
           num(double(bsdf.table_bytes()) / double(std::max<std::uint64_t>(mf.payload_bytes(), 1)), "%.0f") +
           "x less; " + num(double(full) / double(std::max<std::uint64_t>(mf.payload_bytes(), 1)), "%.0f") +
           "x less than the full 4D table)");
  if (figures) run_script("render_figures.py", {"--dir", s.output});
}

}  // namespace render
}  // namespace bsdfmix
