// Kernel shapes per device: of the fitting routines (kernels/em.cl, l1.cl, amplitudes.cl),
// and the work-group of the kernels that take one item per work-item (kernels/sample.cl,
// selftest.cl). A built-in table by device type and vendor, and entries of the fitting
// shapes that `bsdfmix tune` measured, keyed by device name and driver version, read from
// the file $BSDFMIX_SHAPES names.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "device/device.hpp"

namespace bsdfmix {

// Cells per chunk (one work-group): WG * CPW * VEC, the same on every device.
constexpr int kChunkCells = 512;

// CPUs: one work-item per work-group walking VEC-wide float vectors (the CPU compiler
// vectorizes the vector code, not across work-items); others: scalar work-items, WG per
// work-group, with local-memory reductions. CPW = 512 / (VEC * WG).
struct KernelShape {
  int vec = 1, wg = 64, cpw = 8;
  std::string label() const;  // "vec 16 x wg 1"
  bool operator==(const KernelShape& o) const { return vec == o.vec && wg == o.wg && cpw == o.cpw; }
};

// A shape of vec (16, 8, 4 or 1) and wg (a power of two, 1 when vec > 1); ConfigError otherwise.
KernelShape make_shape(int vec, int wg);

// Where a device's shape came from, for the log and `bsdfmix devices`.
struct ShapeChoice {
  KernelShape shape;
  std::string source;  // "table: <row>", "tuned: <file>"
};

// The shape for `info`: a tuned entry of $BSDFMIX_SHAPES for this device name and driver,
// else the built-in table's first matching row; `gpu_layout` forces the scalar layout on
// CPUs. The work-group size never exceeds the device's maximum (halved until it fits).
ShapeChoice choose_shape(const DeviceInfo& info, bool gpu_layout = false);

// The work-group size of the one-item-per-work-item kernels (kernels/sample.cl,
// selftest.cl) on `info`: the built-in table's "items" column, halved to the largest power
// of two within the device's maximum.
std::size_t item_group_size(const DeviceInfo& info);

// `items` rounded up to a whole number of work-groups of `group`.
std::size_t item_global_size(std::size_t items, std::size_t group);

// The shapes `bsdfmix tune` measures on `info` (within its work-group limit).
std::vector<KernelShape> shape_candidates(const DeviceInfo& info);

// One line of a shapes file: "<device name>\t<driver>\t<vec>\t<wg>\t<note>".
std::string shape_entry(const DeviceInfo& info, const KernelShape& shape, const std::string& note);

// The built-in table as text (for docs/em.md and `bsdfmix tune --table`).
std::string shape_table_text();

}  // namespace bsdfmix
