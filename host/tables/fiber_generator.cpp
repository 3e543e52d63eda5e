// The fiber table generator: kernels/fiber.cl driven batch by batch into a TableWriter.
#include "tables/fiber_generator.hpp"

#include <Random123/philox.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <sstream>

#include "core/color.hpp"
#include "core/domain.hpp"
#include "core/error.hpp"
#include "core/format.hpp"
#include "core/progress.hpp"
#include "device/program.hpp"
#include "device/routine.hpp"
#include "io/pfm.hpp"
#include "tables/fiber_presets.hpp"

namespace bsdfmix {

namespace {

// Mirrors the FiberParams struct of kernels/fiber.cl (floats only, no padding).
struct KernelParams {
  cl_float eta, s, logistic_norm;
  cl_float sigma_a[kFiberChannels];
  cl_float v[kFiberLobes];
  cl_float tilt[kFiberLobes];
};
static_assert(sizeof(KernelParams) == 14 * sizeof(cl_float), "KernelParams must match kernels/fiber.cl");

std::string fmt(double x) {
  // The shorter of %.15g / %.17g that reads back exactly.
  const std::string s = format_number(x, "%.15g");
  return std::strtod(s.c_str(), nullptr) == x ? s : format_number(x, "%.17g");
}

constexpr std::uint32_t kNoiseStream = 0x66696265u;  // "fibe": third counter word
constexpr std::size_t kBatchBytes = std::size_t(64) << 20;

std::string fmt_rgb(const FiberRgb& v) {
  return "[" + fmt(v[0]) + ", " + fmt(v[1]) + ", " + fmt(v[2]) + "]";
}

}  // namespace

void validate_fiber_options(const FiberGenerateOptions& opt) {
  auto fail = [](const std::string& what) { throw ConfigError("generate fiber: " + what); };
  fiber_preset(opt.preset);
  if (opt.n_theta_o < 1 || opt.n_theta_o > 100000) fail("theta_o resolution must be in [1, 100000]");
  if (opt.n_theta_i < 2 || opt.n_theta_i > 100000) fail("theta_i resolution must be in [2, 100000]");
  if (opt.n_phi_i < 2 || opt.n_phi_i > 100000) fail("phi_i resolution must be in [2, 100000]");
  if (!opt.symmetry && opt.n_phi_o > 100000) fail("phi_o resolution must be in [1, 100000]");
  if (opt.symmetry && opt.n_phi_o > 1) fail("phi_o resolution must be 1 with azimuthal symmetry");
  if (!(opt.noise >= 0.0 && opt.noise <= 10.0)) fail("noise level must be in [0, 10]");
  if (opt.h_nodes < 2 || opt.h_nodes > 4096) fail("h_nodes must be in [2, 4096]");
  if (opt.deflate < 0 || opt.deflate > 9) fail("deflate level must be in [0, 9]");
}

std::string fiber_source_json(const FiberGenerateOptions& opt) {
  const FiberPreset& preset = fiber_preset(opt.preset);
  const FiberParams& p = preset.params;
  std::ostringstream s;
  s << "{\"model\": \"chiang2016\", \"preset\": \"" << opt.preset << "\", \"eta\": " << fmt(p.eta)
    << ", \"beta_m\": " << fmt(p.beta_m) << ", \"beta_n\": " << fmt(p.beta_n) << ", \"alpha\": " << fmt(p.alpha)
    << ", \"sigma_a\": " << fmt_rgb(p.sigma_a) << ", \"color\": " << fmt_rgb(preset.color)
    << ", \"channels\": \"linear Rec. 709 RGB\", \"noise\": " << fmt(opt.noise) << ", \"seed\": " << opt.seed
    << ", \"h_nodes\": " << opt.h_nodes << "}";
  return s.str();
}

TableMeta fiber_table_meta(const FiberGenerateOptions& opt) {
  validate_fiber_options(opt);
  const std::size_t n_phi_o = opt.symmetry ? 1 : (opt.n_phi_o == 0 ? opt.n_phi_i : opt.n_phi_o);
  TableMeta meta = make_grid(Domain::Fiber, opt.n_theta_o, n_phi_o, opt.n_theta_i, opt.n_phi_i, opt.symmetry);
  meta.source = fiber_source_json(opt);
  meta.rgb = true;
  return meta;
}

FiberModel fiber_model_for(const FiberGenerateOptions& opt) {
  const FiberPreset& preset = fiber_preset(opt.preset);
  const std::string where = "fiber preset " + preset.name;
  return FiberModel(preset.params, opt.h_nodes, where.c_str());
}

double fiber_noise_factor(std::uint64_t cell, std::uint64_t seed, double level) {
  if (level <= 0.0) return 1.0;
  r123::Philox4x32 rng;
  const r123::Philox4x32::ctr_type ctr = {
      {std::uint32_t(cell), std::uint32_t(cell >> 32), kNoiseStream, 0u}};
  const r123::Philox4x32::key_type key = {{std::uint32_t(seed), std::uint32_t(seed >> 32)}};
  const auto r = rng(ctr, key);
  const double u1 = (double(r.v[0] >> 8) + 0.5) / 16777216.0;
  const double u2 = (double(r.v[1] >> 8) + 0.5) / 16777216.0;
  const double z = std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * kPi * u2);
  return std::exp(level * z - 0.5 * level * level);
}

std::vector<double> tabulate_fiber_slice_rgb_cpu(const FiberModel& model, const TableMeta& meta, std::size_t t_o,
                                                 std::size_t p_o, double noise, std::uint64_t seed) {
  if (t_o >= meta.theta_o.size() || p_o >= meta.phi_o.size())
    throw InputError("fiber slice (" + std::to_string(t_o) + ", " + std::to_string(p_o) + ") outside the table");
  const double th_o = meta.theta_o[t_o], ph_o = meta.phi_o[p_o];
  const std::size_t n_ti = meta.theta_i.size(), n_pi = meta.phi_i.size();
  std::vector<double> dphi(n_pi);
  for (std::size_t j = 0; j < n_pi; ++j) dphi[j] = meta.phi_i[j] - ph_o;
  const auto nbar = model.azimuthal_factors(th_o, dphi);
  std::vector<double> out(n_ti * n_pi * kFiberChannels);
  const std::uint64_t first_cell = std::uint64_t(meta.slice_index(t_o, p_o)) * meta.cells_per_slice();
  for (std::size_t i = 0; i < n_ti; ++i) {
    std::array<double, kFiberLobes> m{};
    for (int p = 0; p < kFiberLobes; ++p) m[std::size_t(p)] = model.longitudinal(p, th_o, meta.theta_i[i]);
    for (std::size_t j = 0; j < n_pi; ++j) {
      const double factor = fiber_noise_factor(first_cell + i * n_pi + j, seed, noise);
      for (std::size_t c = 0; c < kFiberChannels; ++c) {
        double v = 0;
        for (std::size_t p = 0; p < kFiberLobes; ++p) v += m[p] * nbar[c][p][j];
        out[(i * n_pi + j) * kFiberChannels + c] = v * factor;
      }
    }
  }
  return out;
}

std::vector<double> tabulate_fiber_slice_cpu(const FiberModel& model, const TableMeta& meta, std::size_t t_o,
                                             std::size_t p_o, double noise, std::uint64_t seed) {
  const std::vector<double> rgb = tabulate_fiber_slice_rgb_cpu(model, meta, t_o, p_o, noise, seed);
  std::vector<double> y(rgb.size() / kFiberChannels);
  for (std::size_t k = 0; k < y.size(); ++k) y[k] = rec709_luminance(rgb[3 * k], rgb[3 * k + 1], rgb[3 * k + 2]);
  return y;
}

void fiber_luminance(const float* rgb, std::size_t cells, float* values) {
  for (std::size_t k = 0; k < cells; ++k) values[k] = luminance(rgb[3 * k], rgb[3 * k + 1], rgb[3 * k + 2]);
}

// ---------------------------------------------------------------------------------------

struct FiberDeviceTabulator::Impl {
  const Device* device = nullptr;
  TableMeta meta;
  std::size_t max_batch = 1;
  double noise = 0;
  std::uint64_t seed = 1;
  cl::CommandQueue queue;
  std::unique_ptr<Routine> k_azimuthal, k_longitudinal, k_combine;
  cl::Buffer rgb;
  std::vector<cl::Event> pending;
  ~Impl() {
    // Reads still in flight write into the caller's memory: let them land first.
    try {
      if (queue()) queue.finish();
    } catch (const cl::Error&) {
    }
  }
};

FiberDeviceTabulator::FiberDeviceTabulator(const Device& device, const FiberModel& model, const TableMeta& meta,
                                           double noise, std::uint64_t seed, std::size_t max_batch)
    : impl_(std::make_unique<Impl>()) {
  Impl& d = *impl_;
  d.device = &device;
  d.meta = meta;
  d.noise = noise;
  d.seed = seed;
  const std::size_t cells = meta.cells_per_slice();
  const std::uint64_t max_alloc = std::max<std::uint64_t>(device.info().max_alloc, 1 << 20);
  const std::size_t by_alloc =
      std::max<std::size_t>(1, std::size_t(max_alloc / (cells * kFiberChannels * sizeof(float))));
  d.max_batch = std::max<std::size_t>(1, std::min({max_batch, meta.n_slices(), by_alloc}));
  if (meta.n_slices() > 0xFFFFFFFFull || cells > 0xFFFFFFFFull)
    throw ConfigError("generate fiber: table too large for 32-bit slice and cell indices");

  const FiberParams& fp = model.params();
  KernelParams kp{};
  kp.eta = cl_float(fp.eta);
  for (int c = 0; c < kFiberChannels; ++c) kp.sigma_a[c] = cl_float(fp.sigma_a[std::size_t(c)]);
  kp.s = cl_float(model.logistic_scale());
  kp.logistic_norm = cl_float(1 / (1 + std::exp(-kPi / model.logistic_scale())) -
                              1 / (1 + std::exp(kPi / model.logistic_scale())));
  const double tilt[kFiberLobes] = {-2 * fp.alpha, fp.alpha, 4 * fp.alpha, 0.0};
  for (int p = 0; p < kFiberLobes; ++p) {
    kp.v[p] = cl_float(model.variance(p));
    kp.tilt[p] = cl_float(tilt[p]);
  }

  auto to_float = [](const std::vector<double>& v) { return std::vector<cl_float>(v.begin(), v.end()); };
  const auto& gl = model.h_quadrature();
  std::vector<cl_float2> rule(gl.nodes.size());
  for (std::size_t k = 0; k < rule.size(); ++k) {
    rule[k].s[0] = cl_float(gl.nodes[k]);
    rule[k].s[1] = cl_float(gl.weights[k]);
  }
  try {
    cl::Program program = build_program(device, "fiber");
    d.queue = device.make_queue();
    const cl::Context& ctx = device.context();
    const cl::Buffer theta_o = upload(device, "theta_o", to_float(meta.theta_o));
    const cl::Buffer phi_o = upload(device, "phi_o", to_float(meta.phi_o));
    const cl::Buffer theta_i = upload(device, "theta_i", to_float(meta.theta_i));
    const cl::Buffer phi_i = upload(device, "phi_i", to_float(meta.phi_i));
    const cl::Buffer nbar = cl::Buffer(
        ctx, CL_MEM_READ_WRITE, d.max_batch * kFiberChannels * kFiberLobes * meta.phi_i.size() * sizeof(cl_float));
    const cl::Buffer m =
        cl::Buffer(ctx, CL_MEM_READ_WRITE, d.max_batch * kFiberLobes * meta.theta_i.size() * sizeof(cl_float));
    d.rgb = cl::Buffer(ctx, CL_MEM_WRITE_ONLY, d.max_batch * cells * kFiberChannels * sizeof(cl_float));

    const cl_uint n_phi_o = cl_uint(meta.phi_o.size()), n_theta_i = cl_uint(meta.theta_i.size()),
                  n_phi_i = cl_uint(meta.phi_i.size());
    d.k_azimuthal = std::make_unique<Routine>(program, "fiber_azimuthal");
    d.k_azimuthal->set("prm", kp).set("theta_o", theta_o).set("phi_o", phi_o).set("phi_i", phi_i)
        .set("h_rule", upload(device, "h_rule", rule)).set("n_h", cl_uint(rule.size())).set("n_phi_o", n_phi_o)
        .set("n_phi_i", n_phi_i).set("nbar", nbar);
    d.k_longitudinal = std::make_unique<Routine>(program, "fiber_longitudinal");
    d.k_longitudinal->set("prm", kp).set("theta_o", theta_o).set("theta_i", theta_i).set("n_phi_o", n_phi_o)
        .set("n_theta_i", n_theta_i).set("m", m);
    d.k_combine = std::make_unique<Routine>(program, "fiber_combine");
    d.k_combine->set("m", m).set("nbar", nbar).set("n_theta_i", n_theta_i).set("n_phi_i", n_phi_i)
        .set("noise", cl_float(noise)).set("seed", cl_ulong(seed)).set("rgb", d.rgb);
  } catch (const cl::Error& e) {
    throw_device_error(e, "fiber tabulation setup on " + device.info().label());
  }
}

FiberDeviceTabulator::~FiberDeviceTabulator() = default;

std::size_t FiberDeviceTabulator::max_batch() const { return impl_->max_batch; }

void FiberDeviceTabulator::enqueue(std::size_t first, std::size_t count, float* rgb) {
  Impl& d = *impl_;
  if (count == 0 || count > d.max_batch || first + count > d.meta.n_slices())
    throw ConfigError("fiber tabulation: batch [" + std::to_string(first) + ", " + std::to_string(first + count) +
                      ") invalid (max batch " + std::to_string(d.max_batch) + ", " +
                      std::to_string(d.meta.n_slices()) + " slices)");
  const std::size_t n_ti = d.meta.theta_i.size(), n_pi = d.meta.phi_i.size();
  try {
    const cl_uint first_u = cl_uint(first), count_u = cl_uint(count);
    d.k_azimuthal->set("first_slice", first_u).set("batch", count_u).run(d.queue, cl::NDRange(n_pi, count));
    d.k_longitudinal->set("first_slice", first_u).set("batch", count_u).run(d.queue, cl::NDRange(n_ti, count));
    d.k_combine->set("first_slice", first_u).set("batch", count_u).run(d.queue, cl::NDRange(n_pi, n_ti, count));
    cl::Event ev;
    d.queue.enqueueReadBuffer(d.rgb, CL_FALSE, 0, count * n_ti * n_pi * kFiberChannels * sizeof(cl_float), rgb,
                              nullptr, &ev);
    d.pending.push_back(ev);
  } catch (const cl::Error& e) {
    throw_device_error(e, "fiber tabulation of slices " + std::to_string(first) + ".." +
                              std::to_string(first + count - 1) + " on " + d.device->info().label());
  }
}

void FiberDeviceTabulator::wait() {
  Impl& d = *impl_;
  try {
    for (auto& ev : d.pending) ev.wait();
    d.pending.clear();
  } catch (const cl::Error& e) {
    d.pending.clear();
    throw_device_error(e, "fiber tabulation on " + d.device->info().label());
  }
}

void FiberDeviceTabulator::compute(std::size_t first, std::size_t count, float* rgb, float* values) {
  enqueue(first, count, rgb);
  wait();
  if (values) fiber_luminance(rgb, count * impl_->meta.cells_per_slice(), values);
}

// ---------------------------------------------------------------------------------------

void generate_fiber_table(const FiberGenerateOptions& opt, const std::string& device_selector,
                          const std::string& out_path) {
  const TableMeta meta = fiber_table_meta(opt);
  const FiberModel model = fiber_model_for(opt);
  std::vector<Device> devices = select_devices(device_selector);
  if (devices.empty()) throw DeviceError("generate fiber: no OpenCL device selected by '" + device_selector + "'");
  const Device& device = devices.front();
  const std::size_t cells = meta.cells_per_slice();
  // Per slice in memory: the rgb channel (3 floats a cell) and the values (1).
  const std::size_t batch = std::max<std::size_t>(1, kBatchBytes / (cells * (kFiberChannels + 1) * sizeof(float)));
  // Two host rgb buffers (declared before the tabulator, which finishes its reads into them
  // when destroyed): the device fills one while the other is written to disk.
  std::array<std::vector<float>, 2> host;
  FiberDeviceTabulator tab(device, model, meta, opt.noise, opt.seed, batch);
  const std::size_t n_slices = meta.n_slices(), b = tab.max_batch();

  log_line("generate fiber " + opt.preset + ": " + std::to_string(meta.theta_o.size()) + " x " +
           std::to_string(meta.phi_o.size()) + " x " + std::to_string(meta.theta_i.size()) + " x " +
           std::to_string(meta.phi_i.size()) + " cells, rgb and luminance, on " + device.info().label() + " -> " +
           out_path);
  TableWriter writer(out_path, meta, opt.deflate);
  Progress progress("generate fiber " + opt.preset, n_slices, "slices");
  host[0].resize(b * cells * kFiberChannels);
  if (n_slices > b) host[1].resize(b * cells * kFiberChannels);
  std::vector<float> values(cells);
  std::size_t first = 0, which = 0;
  std::size_t count = std::min(b, n_slices);
  tab.enqueue(first, count, host[0].data());
  while (first < n_slices) {
    tab.wait();
    const std::size_t next_first = first + count;
    const std::size_t next_count = std::min(b, n_slices - std::min(n_slices, next_first));
    if (next_count > 0) tab.enqueue(next_first, next_count, host[1 - which].data());
    for (std::size_t k = 0; k < count; ++k) {
      const std::size_t s = first + k;
      const float* rgb = host[which].data() + k * cells * kFiberChannels;
      fiber_luminance(rgb, cells, values.data());
      writer.write_slice(s / meta.phi_o.size(), s % meta.phi_o.size(), values.data(), rgb);
    }
    progress.advance(count);
    first = next_first;
    count = next_count;
    which = 1 - which;
  }
  writer.commit();
  progress.finish();
}

}  // namespace bsdfmix
