// OpenCL platforms and devices: enumeration and selection by config, flag or environment.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "device/opencl.hpp"

namespace bsdfmix {

struct DeviceInfo {
  int index = 0;           // global index across all platforms, as `bsdfmix devices` prints it
  int platform_index = 0;
  std::string platform, name, vendor, version, driver, type;  // type: cpu, gpu, accelerator, other
  unsigned compute_units = 0;
  std::uint64_t global_mem = 0, local_mem = 0, max_alloc = 0;
  std::size_t max_work_group = 0;
  bool fp64 = false;
  bool is_cpu() const { return type == "cpu"; }
  // Whether the implementation takes calls from several host threads at once, as OpenCL
  // requires: oclgrind (21.10) crashes when two threads run kernels (jrprice/Oclgrind#28).
  bool concurrent_host_threads() const { return platform.find("Oclgrind") == std::string::npos; }
  std::string label() const;  // "name [platform]"
};

// The programs built for one device's context, keyed by (name, build options): owned by the
// Device (shared by its copies), so that every cl::Program is released while the OpenCL
// runtime is still there, never during static destruction (which some implementations,
// oclgrind among them, do not survive).
struct ProgramCache {
  std::mutex mutex;
  std::map<std::pair<std::string, std::string>, cl::Program> programs;
};

// One selected device with its own context.
class Device {
 public:
  Device(cl::Device device, DeviceInfo info);
  const DeviceInfo& info() const { return info_; }
  const cl::Device& cl_device() const { return device_; }
  const cl::Context& context() const { return context_; }
  cl::CommandQueue make_queue(bool profiling = false) const;
  ProgramCache& programs() const { return *programs_; }

 private:
  cl::Device device_;
  cl::Context context_;
  DeviceInfo info_;
  std::shared_ptr<ProgramCache> programs_ = std::make_shared<ProgramCache>();
};

// Every device of every platform. Throws DeviceError, saying how to install PoCL,
// when there is no OpenCL platform at all.
std::vector<DeviceInfo> enumerate_devices();

// Chooses devices by `selector`; an empty selector falls back to $BSDFMIX_DEVICE,
// then to device 0. A selector is a comma-separated list of items, each an index,
// "all", a type ("cpu", "gpu") or a case-insensitive substring of the device,
// platform or vendor name. Throws DeviceError when an item matches nothing.
std::vector<Device> select_devices(const std::string& selector);

// The selector in effect: `selector`, else $BSDFMIX_DEVICE, else "0".
std::string effective_selector(const std::string& selector);

}  // namespace bsdfmix
