// Tabulates the fiber model into a table file (docs/formats.md, "Table file"), slice batches
// evaluated by kernels/fiber.cl and streamed to disk; plus the CPU path the tests use.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "device/device.hpp"
#include "io/table.hpp"
#include "tables/fiber_model.hpp"

namespace bsdfmix {

struct FiberGenerateOptions {
  std::string preset = "silk";
  std::size_t n_theta_o = 180, n_theta_i = 90, n_phi_i = 180;
  bool symmetry = true;       // azimuthal symmetry: one phi_o slice per theta_o
  std::size_t n_phi_o = 0;    // without symmetry; 0: the same as n_phi_i
  double noise = 0.0;         // multiplicative log-normal noise, sigma of log f; 0: none
  std::uint64_t seed = 1;     // noise seed
  std::size_t h_nodes = kFiberHNodes;
  int deflate = 0;            // the file's compression (TableWriter): 0 none, 1..9 shuffle + deflate
};

// Checks the options (resolutions, noise, preset); throws ConfigError naming the option.
void validate_fiber_options(const FiberGenerateOptions& opt);

// The table grid (with the `rgb` channel) and the `source` JSON of the options.
TableMeta fiber_table_meta(const FiberGenerateOptions& opt);
std::string fiber_source_json(const FiberGenerateOptions& opt);

// The model of the options' preset.
FiberModel fiber_model_for(const FiberGenerateOptions& opt);

// The noise factor of table cell `cell` (global row-major index over the 4D table):
// exp(level z - level^2 / 2), z standard normal from Philox4x32-10 keyed by `seed` with
// counter `cell` (Box-Muller). Mean 1, never negative, independent of batching. 1 when
// level is 0.
double fiber_noise_factor(std::uint64_t cell, std::uint64_t seed, double level);

// CPU reference of one slice (t_o, p_o) of the table `meta` in double precision, noise
// included (one factor per cell for its three channels): the rgb channel, row-major
// [theta_i][phi_i][R, G, B]; and `values`, its luminance (core/color.hpp), [theta_i][phi_i].
std::vector<double> tabulate_fiber_slice_rgb_cpu(const FiberModel& model, const TableMeta& meta, std::size_t t_o,
                                                 std::size_t p_o, double noise = 0.0, std::uint64_t seed = 1);
std::vector<double> tabulate_fiber_slice_cpu(const FiberModel& model, const TableMeta& meta, std::size_t t_o,
                                             std::size_t p_o, double noise = 0.0, std::uint64_t seed = 1);

// The table's `values` from its `rgb`: values[k] = luminance of rgb[3k .. 3k + 2], for
// `cells` cells (the float luminance of io/pfm.hpp: exactly R where R = G = B).
void fiber_luminance(const float* rgb, std::size_t cells, float* values);

// Device evaluation of consecutive slices of a table with kernels/fiber.cl.
class FiberDeviceTabulator {
 public:
  FiberDeviceTabulator(const Device& device, const FiberModel& model, const TableMeta& meta, double noise,
                       std::uint64_t seed, std::size_t max_batch);
  ~FiberDeviceTabulator();
  FiberDeviceTabulator(const FiberDeviceTabulator&) = delete;
  FiberDeviceTabulator& operator=(const FiberDeviceTabulator&) = delete;

  std::size_t max_batch() const;
  // Enqueues slices [first, first + count) (global slice index t_o * n_phi_o + p_o) and a
  // non-blocking read of their rgb channel into `rgb` (count * cells_per_slice * 3 floats,
  // [slice][theta_i][phi_i][R, G, B]); wait() blocks until done.
  void enqueue(std::size_t first, std::size_t count, float* rgb);
  void wait();
  // enqueue + wait; then, when `values` is given, the luminance of each cell
  // (count * cells_per_slice floats, fiber_luminance).
  void compute(std::size_t first, std::size_t count, float* rgb, float* values = nullptr);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Tabulates the options' preset on the first device of `device_selector` into `out_path`,
// batch by batch (each batch at most about 64 MB), with a progress line. The file appears
// only when complete.
void generate_fiber_table(const FiberGenerateOptions& opt, const std::string& device_selector,
                          const std::string& out_path);

}  // namespace bsdfmix
