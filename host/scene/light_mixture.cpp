// The lighting's mixture: cell weights, fitted in memory by the sweep, and the cache.
#include "scene/light_mixture.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <stdexcept>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "core/hash.hpp"
#include "core/progress.hpp"
#include "io/mixture_file.hpp"
#include "device/device.hpp"
#include "sweep/fit_slices.hpp"
#include "sweep/slice_source.hpp"
#include "sweep/sweep.hpp"

namespace bsdfmix {

std::vector<double> lighting_cell_weights(const Lighting& light, const TableMeta& grid) {
  const std::size_t nt = grid.theta_i.size(), np = grid.phi_i.size();
  const double dth = axis_step(grid.theta_i), dph = axis_step(grid.phi_i);
  const int n = light.is_constant()
                    ? 1
                    : std::clamp(int(std::ceil(3.0 * std::max(dth, dph) / std::max(light.finest_feature(), 1e-9))), 2, 12);
  std::vector<double> w(nt * np, 0.0);
  for (std::size_t i = 0; i < nt; ++i)
    for (std::size_t j = 0; j < np; ++j) {
      double acc = 0;
      for (int a = 0; a < n; ++a)
        for (int b = 0; b < n; ++b) {
          const double th = grid.theta_i[i] + dth * ((a + 0.5) / n - 0.5);
          const double ph = grid.phi_i[j] + dph * ((b + 0.5) / n - 0.5);
          acc += light.radiance(th, ph);
        }
      w[i * np + j] = acc / (n * n) * dth * dph;
    }
  return w;
}

namespace {

// The lighting's cells as the one slice a sweep fits, on the table's grid (one omega_o).
// The sweep's weights are f c J x cell area; a table holds f as float32, and so do these
// cells: f = float(L cell integral / (c J x cell area)), so that the lighting is fitted at
// a table's precision and its mixtures are those a table of the same cells gives.
// The weights are L dtheta dphi for a fit in (theta, phi), whose mixture then follows L
// per unit of (theta, phi), and L J dtheta dphi (L over the cell's solid angle) on an
// equal-area map, whose mixture then follows L per steradian: either way its product with
// the BSDF mixture in the same plane follows the integrand in that plane.
class LightingSlices final : public SliceSource {
 public:
  LightingSlices(const Lighting& light, const TableMeta& grid, const std::string& name, bool per_steradian)
      : meta_(grid) {
    meta_.azimuthal = true;
    meta_.theta_o = {grid.theta_o.empty() ? 0.0 : grid.theta_o.front()};
    meta_.phi_o = {0.0};
    meta_.rgb = false;
    meta_.source = "{\"lighting\": \"" + name + "\", \"weights\": \"L_i " + (per_steradian ? "J " : "") +
                   "dtheta dphi / (c J dtheta dphi)\"}";
    std::vector<double> w = lighting_cell_weights(light, meta_);
    const std::size_t np = meta_.phi_i.size();
    if (per_steradian)
      for (std::size_t c = 0; c < w.size(); ++c) w[c] *= jacobian(meta_.domain, meta_.theta_i[c / np]);
    const std::vector<float> ones(w.size(), 1.f);
    const std::vector<double> g = integrand_weights(meta_.domain, meta_.theta_i, meta_.phi_i, ones.data());
    std::vector<float> f(w.size());
    for (std::size_t c = 0; c < w.size(); ++c) f[c] = g[c] > 0 ? float(w[c] / g[c]) : 0.f;
    weights_ = integrand_weights(meta_.domain, meta_.theta_i, meta_.phi_i, f.data());
  }
  const TableMeta& meta() const override { return meta_; }
  std::vector<double> weights(const SliceRef&) const override { return weights_; }

 private:
  TableMeta meta_;
  std::vector<double> weights_;
};

}  // namespace

LightMixture lighting_mixture(const Lighting& light, const TableMeta& grid, const FitSettings& fit,
                              const std::string& cache_dir, const std::string& device_selector,
                              const EngineOptions& engine) {
  if (fit.map == "auto")  // a product multiplies two mixtures of one plane: the BSDF mixture's
    throw std::logic_error("lighting_mixture: fit.map must be the BSDF mixture's map, not auto");
  // The cache key: everything the fit depends on.
  Hash64 h;
  const std::vector<float> packed = light.pack();
  h.update(packed.data(), packed.size() * sizeof(float));
  h.update(light.env.data(), light.env.size() * sizeof(float));
  h.update(std::uint64_t(light.domain == Domain::Fiber ? 1 : 2));
  h.update(grid.theta_i.data(), grid.theta_i.size() * sizeof(double));
  h.update(grid.phi_i.data(), grid.phi_i.size() * sizeof(double));
  const bool per_steradian = fit.map == "equal_area";
  const std::string settings =
      fit_settings_json(fit) + "," + BSDFMIX_VERSION + (per_steradian ? ",L per steradian" : "");
  h.update(settings.data(), settings.size());
  std::string name = light.name;
  for (char& c : name)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '-' && c != '_') c = '_';
  const std::string stem = (std::filesystem::path(cache_dir) / ("light_" + name + "_" + h.hex())).string();

  LightMixture out;
  out.path = stem + ".h5";
  if (!std::filesystem::exists(out.path)) {
    std::filesystem::create_directories(cache_dir);
    log_line("converge: fitting the lighting of scene '" + light.name + "' (" + out.path + ")");
    const auto t0 = std::chrono::steady_clock::now();
    const LightingSlices cells(light, grid, name, per_steradian);
    SweepResult fitted = fit_slices(cells, {SliceRef{0, 0, 0}}, fit, select_devices(device_selector),
                                    "fit the lighting '" + name + "'", engine);
    out.fit_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    write_mixture_file(out.path, fitted.mixture);
    write_text_atomic(stem + "_seconds.txt", std::to_string(out.fit_seconds) + "\n");
  } else {
    out.cached = true;
    std::ifstream in(stem + "_seconds.txt");  // how long the fit took when it was made
    if (!(in >> out.fit_seconds)) out.fit_seconds = 0;
  }
  const MixtureFile mf = read_mixture_file(out.path);
  if (mf.slices() != 1) throw InputError(out.path + ": a lighting mixture holds one slice, not " + std::to_string(mf.slices()));
  const mix::MixtureSet set = to_mixture_set(mf);
  out.mixture = set.slices.front();
  out.k = mf.k.front();
  out.l1_rel = mf.l1_rel.front();
  return out;
}

}  // namespace bsdfmix
