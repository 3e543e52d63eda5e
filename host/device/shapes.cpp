// The per-device kernel shape table, and tuned entries read from $BSDFMIX_SHAPES.
#include "device/shapes.hpp"

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "core/error.hpp"

namespace bsdfmix {

namespace {

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

// The built-in table: the first row whose type and vendor (a case-insensitive substring
// of the vendor or platform name, "" for any) match. Rows are measured defaults
// (docs/em.md "Kernel shapes"); a tuned entry overrides them.
struct Row {
  const char* type;    // "cpu", "gpu", "" (any)
  const char* vendor;  // substring, "" (any)
  int vec, wg;
  int items;  // work-group of the one-item-per-work-item kernels (item_group_size)
  const char* why;
};
const Row kTable[] = {
    {"cpu", "", 16, 1, 64, "CPUs: 16-wide float vectors, one work-item per group (PoCL measured)"},
    {"gpu", "nvidia", 1, 64, 64, "NVIDIA GPUs: 64 scalar work-items (two warps)"},
    {"gpu", "advanced micro devices", 1, 64, 64, "AMD GPUs: one wavefront of 64"},
    {"gpu", "intel", 1, 64, 64, "Intel GPUs: 64 scalar work-items"},
    {"", "", 1, 64, 64, "any other device (oclgrind included): 64 scalar work-items"},
};

bool row_matches(const Row& r, const DeviceInfo& info) {
  if (*r.type && info.type != r.type) return false;
  if (!*r.vendor) return true;
  return lower(info.vendor).find(r.vendor) != std::string::npos ||
         lower(info.platform).find(r.vendor) != std::string::npos;
}

// The first row that matches `info` (the last row matches every device).
const Row& row_for(const DeviceInfo& info) {
  for (const Row& r : kTable)
    if (row_matches(r, info)) return r;
  return kTable[sizeof(kTable) / sizeof(kTable[0]) - 1];
}

int largest_power_of_two_at_most(std::size_t n) {
  int p = 1;
  while (static_cast<std::size_t>(p) * 2 <= n) p *= 2;
  return p;
}

KernelShape fit_device(KernelShape s, const DeviceInfo& info) {
  if (info.max_work_group && static_cast<std::size_t>(s.wg) > info.max_work_group)
    s = make_shape(s.vec, largest_power_of_two_at_most(info.max_work_group));
  return s;
}

}  // namespace

std::string KernelShape::label() const {
  return "vec " + std::to_string(vec) + " x wg " + std::to_string(wg);
}

KernelShape make_shape(int vec, int wg) {
  if (vec != 1 && vec != 4 && vec != 8 && vec != 16)
    throw ConfigError("kernel shape: vec " + std::to_string(vec) + " is not 16, 8, 4 or 1");
  if (wg < 1 || (wg & (wg - 1)) || wg > kChunkCells / vec)
    throw ConfigError("kernel shape: wg " + std::to_string(wg) + " is not a power of two up to " +
                      std::to_string(kChunkCells / vec));
  if (vec > 1 && wg > 1) throw ConfigError("kernel shape: vectors (vec " + std::to_string(vec) + ") run one work-item per group (wg 1)");
  return KernelShape{vec, wg, kChunkCells / (vec * wg)};
}

ShapeChoice choose_shape(const DeviceInfo& info, bool gpu_layout) {
  if (const char* path = std::getenv("BSDFMIX_SHAPES"); path && *path && !gpu_layout) {
    std::ifstream in(path);
    if (!in) throw ConfigError("BSDFMIX_SHAPES: cannot read " + std::string(path));
    std::string line;
    int number = 0;
    while (std::getline(in, line)) {
      ++number;
      if (line.empty() || line[0] == '#') continue;
      std::vector<std::string> f;
      std::stringstream ss(line);
      for (std::string x; std::getline(ss, x, '\t');) f.push_back(x);
      if (f.size() < 4)
        throw ConfigError(std::string(path) + ":" + std::to_string(number) +
                          ": expected <device>\\t<driver>\\t<vec>\\t<wg>[\\t<note>]");
      if (f[0] != info.name || f[1] != info.driver) continue;
      int vec = 0, wg = 0;
      try {
        vec = std::stoi(f[2]);
        wg = std::stoi(f[3]);
      } catch (const std::exception&) {
        throw ConfigError(std::string(path) + ":" + std::to_string(number) + ": vec and wg must be integers");
      }
      const std::string where = std::string(path) + ":" + std::to_string(number);
      try {
        return {fit_device(make_shape(vec, wg), info), "tuned: " + where};
      } catch (const ConfigError& e) {
        throw ConfigError(where + ": " + e.what());
      }
    }
  }
  if (gpu_layout) return {fit_device(make_shape(1, 64), info), "gpu layout forced"};
  const Row& r = row_for(info);
  return {fit_device(make_shape(r.vec, r.wg), info), std::string("table: ") + r.why};
}

std::size_t item_group_size(const DeviceInfo& info) {
  const std::size_t items = static_cast<std::size_t>(row_for(info).items);
  if (info.max_work_group && items > info.max_work_group)
    return static_cast<std::size_t>(largest_power_of_two_at_most(info.max_work_group));
  return items;
}

std::size_t item_global_size(std::size_t items, std::size_t group) {
  return (items + group - 1) / group * group;
}

std::vector<KernelShape> shape_candidates(const DeviceInfo& info) {
  std::vector<KernelShape> out;
  if (info.is_cpu())
    for (int vec : {16, 8, 4}) out.push_back(make_shape(vec, 1));
  for (int wg : {32, 64, 128, 256})
    if (!info.max_work_group || static_cast<std::size_t>(wg) <= info.max_work_group) out.push_back(make_shape(1, wg));
  return out;
}

std::string shape_entry(const DeviceInfo& info, const KernelShape& shape, const std::string& note) {
  return info.name + "\t" + info.driver + "\t" + std::to_string(shape.vec) + "\t" + std::to_string(shape.wg) + "\t" + note;
}

std::string shape_table_text() {
  std::ostringstream os;
  os << "| type | vendor | vec | wg | items | why |\n|---|---|---|---|---|---|\n";
  for (const Row& r : kTable)
    os << "| " << (*r.type ? r.type : "any") << " | " << (*r.vendor ? r.vendor : "any") << " | " << r.vec << " | " << r.wg
       << " | " << r.items << " | " << r.why << " |\n";
  return os.str();
}

}  // namespace bsdfmix
