// The RGL importer: evaluates the measured BRDF on every cell center, slices in parallel.
#include "tables/rgl_import.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <filesystem>
#include <thread>
#include <vector>

#include "core/error.hpp"
#include "core/format.hpp"
#include "core/progress.hpp"
#include "io/table.hpp"
#include "tables/rgl_brdf.hpp"
#include "tables/rgl_lobe.hpp"
#include "tables/rgl_warnings.hpp"

namespace bsdfmix {

const char* rgl_negative_name(RglNegative n) { return n == RglNegative::Clip ? "clip" : "keep"; }

bool parse_rgl_negative(const std::string& name, RglNegative& out) {
  if (name == "keep") out = RglNegative::Keep;
  else if (name == "clip") out = RglNegative::Clip;
  else return false;
  return true;
}

namespace {

// Raises the resolutions to the grid that resolves the narrowest lobe and logs it.
void log_resolved_grid(const std::string& name, const std::vector<RglLobe>& lobes, std::size_t& n_theta_o,
                       std::size_t& n_theta_i, std::size_t& n_phi_i) {
  constexpr double kToDegrees = 57.29577951308232;
  const RglGrid g = rgl_resolving_grid(lobes, n_theta_o, n_theta_i, n_phi_i);
  n_theta_o = g.n_theta_o;
  n_theta_i = g.n_theta_i;
  n_phi_i = g.n_phi_i;
  const double cells = double(n_theta_o) * double(n_theta_i) * double(n_phi_i);
  log_line(name + ": narrowest lobe " + format_number(g.narrowest.fwhm_theta * kToDegrees, "%.2f") + " x " +
           format_number(g.narrowest.fwhm_phi * kToDegrees, "%.2f") + " degrees (half-maximum width along theta_i, and along phi_i "
           "on its arc) at theta_o " + format_number(g.narrowest.theta_o * kToDegrees, "%.1f") + " degrees: grid " +
           std::to_string(n_theta_o) + " x " + std::to_string(n_theta_i) + " x " + std::to_string(n_phi_i) +
           " (theta_o x theta_i x phi_i), " + rgl_table_bytes(cells) + " of float32 luminance and rgb");
}

}  // namespace

void import_rgl_table(const RglImportOptions& opt, const std::string& out_path) {
  if (opt.n_theta_o < 1 || opt.n_theta_i < 1 || opt.n_phi_i < 1)
    throw InputError("import rgl " + opt.file + ": resolutions must be >= 1 (theta_o " +
                     std::to_string(opt.n_theta_o) + ", theta_i " + std::to_string(opt.n_theta_i) + ", phi_i " +
                     std::to_string(opt.n_phi_i) + ")");
  const RglBrdf brdf(opt.file);
  const std::string name = std::filesystem::path(opt.file).filename().string();
  std::size_t n_theta_o = opt.n_theta_o, n_theta_i = opt.n_theta_i, n_phi_i = opt.n_phi_i;
  // The lobes set the grid under --resolve, and tell whether the grid misses the peak.
  const std::vector<RglLobe> lobes = rgl_lobes(brdf);
  if (opt.resolve) log_resolved_grid(name, lobes, n_theta_o, n_theta_i, n_phi_i);

  TableMeta meta = make_grid(Domain::Hemisphere, n_theta_o, 1, n_theta_i, n_phi_i, true);
  meta.rgb = true;
  if (brdf.rounding_zeros())
    log_line(name + ": " + std::to_string(brdf.rounding_zeros()) +
             " value(s) of its non-negative fields within float rounding below zero, read as 0");
  // "negative" is written only when clipped: a kept table's source is what it always was.
  meta.source = "{\"model\": \"rgl\", \"file\": \"" + name + "\", \"sha256\": \"" + brdf.sha256() + "\"" +
                (opt.negative == RglNegative::Clip ? ", \"negative\": \"clip\"" : "") + "}";
  const bool clip = opt.negative == RglNegative::Clip;

  const std::size_t n_to = meta.theta_o.size(), n_ti = meta.theta_i.size(), n_pi = meta.phi_i.size();
  const std::size_t cells = n_ti * n_pi;
  // Light directions of the cells, shared by every slice.
  std::vector<std::array<double, 3>> wi(cells);
  for (std::size_t t = 0; t < n_ti; ++t)
    for (std::size_t p = 0; p < n_pi; ++p) {
      const double st = std::sin(meta.theta_i[t]), ct = std::cos(meta.theta_i[t]);
      wi[t * n_pi + p] = {st * std::cos(meta.phi_i[p]), st * std::sin(meta.phi_i[p]), ct};
    }

  unsigned threads = opt.threads ? opt.threads : std::max(1u, std::thread::hardware_concurrency());
  const std::size_t batch = std::max<std::size_t>(threads, 1) * 2;
  TableWriter writer(out_path, meta);
  Progress progress("import " + name, n_to, "slices");
  std::atomic<std::size_t> negative{0}, negative_channel{0};
  std::vector<float> slice_max(n_to, 0.0f);  // the largest f of each slice

  std::vector<std::vector<float>> values(batch), rgb(batch);
  for (std::size_t first = 0; first < n_to; first += batch) {
    const std::size_t count = std::min(batch, n_to - first);
    std::atomic<std::size_t> next{0};
    auto work = [&] {
      for (std::size_t j; (j = next++) < count;) {
        const double to = meta.theta_o[first + j];
        const std::array<double, 3> wo = {std::sin(to), 0.0, std::cos(to)};  // phi_o = 0
        auto& v = values[j];
        auto& c = rgb[j];
        v.assign(cells, 0.0f);
        c.assign(cells * 3, 0.0f);
        std::size_t neg = 0, neg_channel = 0;
        for (std::size_t k = 0; k < cells; ++k) {
          RglValue f = brdf.eval(wo, wi[k]);
          if (f.rgb[0] < 0.0 || f.rgb[1] < 0.0 || f.rgb[2] < 0.0) {
            ++neg_channel;
            if (clip) {
              for (double& ch : f.rgb) ch = std::max(0.0, ch);
              f.y = rgb_luminance(f.rgb[0], f.rgb[1], f.rgb[2]);
            }
          }
          // The fit target is a density: a negative luminance (of signed channels) would
          // make it invalid, so it is stored as 0 and counted; rgb keeps the channels.
          if (f.y < 0.0) ++neg;
          v[k] = float(std::max(0.0, f.y));
          for (int ch = 0; ch < 3; ++ch) c[k * 3 + ch] = float(f.rgb[ch]);
        }
        negative += neg;
        negative_channel += neg_channel;
        slice_max[first + j] = *std::max_element(v.begin(), v.end());
        progress.advance();
      }
    };
    std::vector<std::thread> pool;
    const unsigned n_threads = unsigned(std::min<std::size_t>(threads, count));
    for (unsigned t = 1; t < n_threads; ++t) pool.emplace_back(work);
    work();
    for (auto& th : pool) th.join();
    for (std::size_t j = 0; j < count; ++j) writer.write_slice(first + j, 0, values[j].data(), rgb[j].data());
  }
  writer.commit();
  progress.finish();
  const std::string coarse = rgl_coarse_grid_warning(name, lobes, *std::max_element(slice_max.begin(), slice_max.end()),
                                                     n_theta_o, n_theta_i, n_phi_i, opt.resolve);
  if (!coarse.empty()) warn_line(coarse);
  const std::string signed_channels = rgl_negative_warning(name, negative_channel, n_to * cells, clip);
  if (!signed_channels.empty()) warn_line(signed_channels);
  else if (negative_channel)
    log_line(name + ": " + std::to_string(negative_channel.load()) + " of " + std::to_string(n_to * cells) +
             " cells hold a negative channel (out of the sRGB gamut), clipped to 0");
  if (negative) log_line(name + ": " + std::to_string(negative.load()) + " cells with negative luminance stored as 0");
}

}  // namespace bsdfmix
