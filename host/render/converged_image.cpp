// The render's converged image (its reference): cached under its key, checkpointed as it goes.
#include "render/converged_image.hpp"

#include <filesystem>
#include <fstream>
#include <sstream>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "core/hash.hpp"
#include "core/format.hpp"
#include "core/progress.hpp"
#include "io/h5.hpp"

namespace bsdfmix {
namespace render {

namespace fs = std::filesystem;

namespace {

// The checkpoint of an unfinished reference: an HDF5 file (the sweep's parts are HDF5
// too) holding the per-pixel sums of the first `passes` passes, the key they were made
// under, written atomically. Read back only under the same key and size.
struct Partial {
  int passes = 0;
  std::vector<double> sum;
};

void write_partial(const std::string& path, const std::string& key, int width, int height, const Partial& p) {
  AtomicOutput out(path);
  {
    h5::Handle f = h5::create_file(out.temp_path());
    h5::Handle g = h5::create_group(f.get(), "reference", path);
    h5::write_doubles(g.get(), "sum", {hsize_t(height), hsize_t(width), 3}, p.sum.data(), path);
    const std::int32_t passes = p.passes;
    h5::write_ints(g.get(), "passes", {1}, &passes, path);
    h5::write_string_attr(g.get(), "key", key, path);
    if (H5Fflush(f.get(), H5F_SCOPE_GLOBAL) < 0) throw IoError(path + ": flush failed (disk full?)");
  }
  out.commit();
}

// The checkpoint at `path` when it was made under `key` for this size, else none (passes 0).
Partial read_partial(const std::string& path, const std::string& key, int width, int height, int max_passes) {
  Partial p;
  if (!fs::exists(path)) return p;
  try {
    h5::Handle f = h5::open_file(path);
    h5::Handle g = h5::open_group(f.get(), "reference", path);
    if (h5::read_string_attr(g.get(), "key", path) != key) return p;
    const std::vector<std::int32_t> passes = h5::read_ints(g.get(), "passes", path);
    std::vector<double> sum = h5::read_doubles(g.get(), "sum", path);
    if (passes.size() != 1 || passes[0] < 0 || passes[0] > max_passes ||
        sum.size() != 3 * std::size_t(width) * std::size_t(height))
      return p;
    p.passes = passes[0];
    p.sum = std::move(sum);
  } catch (const Error&) {
    return Partial{};  // unreadable (another version's, or damaged): start over
  }
  return p;
}

// The hash of the running executable (its code and embedded kernels): a build that renders
// the reference another way gets another key. "unknown" where /proc/self/exe cannot be read.
std::string code_hash() {
  try {
    return hex64(hash_file("/proc/self/exe"));
  } catch (const Error&) {
    return "unknown";
  }
}

}  // namespace

std::string scene_key(const RenderSettings& s, const std::string& table, std::uint64_t table_hash) {
  std::ostringstream k;
  k << "table " << table << " " << hex64(table_hash) << "\nsize " << s.width << "x" << s.height << "\ndepth "
    << s.max_depth << " " << s.rr_depth << "\nseed " << s.seed << "\ncamera";
  for (int i = 0; i < 3; ++i) k << " " << s.camera.position[i] << " " << s.camera.look_at[i] << " " << s.camera.up[i];
  k << " " << s.camera.fov_deg << "\ncloth " << s.cloth.weave << " " << s.cloth.size << " " << s.cloth.yarn_spacing << " "
    << s.cloth.yarn_radius << " " << s.cloth.plies << " " << s.cloth.ply_twist << " " << s.cloth.fibers_per_ply << " "
    << s.cloth.fiber_twist << " " << s.cloth.fiber_radius << " " << s.cloth.jitter << " " << s.cloth.segments_per_spacing
    << " " << s.cloth.seed << " " << s.cloth.drape << " " << s.cloth.drape_radius << "\nground " << s.ground.enabled << " "
    << s.ground.z << " " << s.ground_albedo;
  if (s.room.enabled) {  // only when on: a render without the room keeps its key
    k << "\nroom " << s.room.albedo << " " << s.room.window << " " << s.room.window_min[0] << " " << s.room.window_min[1]
      << " " << s.room.window_max[0] << " " << s.room.window_max[1];
    for (int i = 0; i < 3; ++i) k << " " << s.room.min[i] << " " << s.room.max[i];
  }
  k << "\nlight";
  for (float x : s.lighting.pack()) k << " " << x;
  Hash64 h;
  h.update(s.lighting.env.data(), s.lighting.env.size() * sizeof(float));
  k << " env " << h.hex() << "\nreference " << path_estimator_name(s.reference_estimator) << " " << s.reference_spp
    << "\nimage rgb\nversion " << BSDFMIX_VERSION << "\ncode " << code_hash() << "\n";
  return k.str();
}

Image mean_image(const std::vector<double>& sum, int passes, int width, int height) {
  Image im(width, height);
  for (std::size_t i = 0; i < im.v.size(); ++i) im.v[i] = float(sum[i] / std::max(passes, 1));
  return im;
}

void save_image(const std::string& dir, const std::string& stem, const Image& image) {
  write_exr((fs::path(dir) / (stem + ".exr")).string(), image);
  write_pfm((fs::path(dir) / (stem + ".pfm")).string(), image);
}

Image converged_image(const SceneView& view, const RenderSettings& s, const std::string& key) {
  const std::string key_path = (fs::path(s.output) / "reference.key").string();
  const std::string pfm = (fs::path(s.output) / "reference.pfm").string();
  if (fs::exists(pfm) && read_text(key_path) == key) {
    log_line("render: reference read from " + pfm);
    return read_pfm_image(pfm);
  }
  // The reference is the long part: its sums are checkpointed every 1/16 of it, and a killed
  // run resumes from the last checkpoint of the same key (pass i always draws the same
  // numbers, so the result is the same as an uninterrupted run's).
  const std::string ckpt = (fs::path(s.output) / "reference.partial.h5").string();
  Partial p = read_partial(ckpt, key, s.width, s.height, s.reference_spp);
  const int done = p.passes;
  if (done > 0)
    log_line("render: the reference resumes at " + std::to_string(done) + " of " + std::to_string(s.reference_spp) +
             " spp (" + ckpt + ")");
  Progress prog("render reference", std::uint64_t(s.reference_spp), "spp");
  prog.advance(std::uint64_t(done));
  const int every = std::max(1, s.reference_spp / 16);
  const RenderStats st =
      render_passes(view, s.reference_estimator, FSource::Table, done, s.reference_spp - done, p.sum, [&](int n, double) {
        prog.advance();
        if ((done + n) % every == 0 && done + n < s.reference_spp) {
          p.passes = done + n;
          write_partial(ckpt, key, s.width, s.height, p);
        }
        return true;
      });
  prog.finish();
  log_line("render: reference: " + std::to_string(s.reference_spp) + " spp (" + std::to_string(st.spp) + " in " +
           format_number(st.seconds, "%.1f") + " s, " + format_number(double(st.rays) / std::max(st.seconds, 1e-9) / 1e6, "%.2f") +
           " M rays/s)");
  const Image reference = mean_image(p.sum, s.reference_spp, s.width, s.height);
  save_image(s.output, "reference", reference);
  write_text_atomic(key_path, key);
  fs::remove(ckpt);
  return reference;
}

}  // namespace render
}  // namespace bsdfmix
