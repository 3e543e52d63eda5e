// OpenCL platforms and devices: enumeration and selection.
#include "device/device.hpp"

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <sstream>

#include "core/error.hpp"

namespace bsdfmix {

namespace {

constexpr const char* kNoPlatform =
    "no OpenCL platform found: install one, for example PoCL for the CPU "
    "(apt-get install pocl-opencl-icd), or your GPU vendor's OpenCL driver";

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

std::string type_name(cl_device_type t) {
  if (t & CL_DEVICE_TYPE_GPU) return "gpu";
  if (t & CL_DEVICE_TYPE_CPU) return "cpu";
  if (t & CL_DEVICE_TYPE_ACCELERATOR) return "accelerator";
  return "other";
}

std::string trim(std::string s) {
  while (!s.empty() && (std::isspace(static_cast<unsigned char>(s.back())) || s.back() == '\0'))
    s.pop_back();
  std::size_t b = 0;
  while (b < s.size() && std::isspace(static_cast<unsigned char>(s[b]))) ++b;
  return s.substr(b);
}

struct Found {
  cl::Device device;
  DeviceInfo info;
};

std::vector<Found> enumerate_all() {
  std::vector<cl::Platform> platforms;
  try {
    cl::Platform::get(&platforms);
  } catch (const cl::Error& e) {
    if (e.err() == -1001 /* CL_PLATFORM_NOT_FOUND_KHR */) throw DeviceError(kNoPlatform);
    throw_device_error(e, "listing OpenCL platforms");
  }
  if (platforms.empty()) throw DeviceError(kNoPlatform);
  std::vector<Found> out;
  for (std::size_t p = 0; p < platforms.size(); ++p) {
    std::vector<cl::Device> devices;
    try {
      platforms[p].getDevices(CL_DEVICE_TYPE_ALL, &devices);
    } catch (const cl::Error& e) {
      if (e.err() == CL_DEVICE_NOT_FOUND) continue;
      throw_device_error(e, "listing devices of platform " + std::to_string(p));
    }
    for (auto& d : devices) {
      DeviceInfo i;
      i.index = static_cast<int>(out.size());
      i.platform_index = static_cast<int>(p);
      i.platform = trim(platforms[p].getInfo<CL_PLATFORM_NAME>());
      i.name = trim(d.getInfo<CL_DEVICE_NAME>());
      i.vendor = trim(d.getInfo<CL_DEVICE_VENDOR>());
      i.version = trim(d.getInfo<CL_DEVICE_VERSION>());
      i.driver = trim(d.getInfo<CL_DRIVER_VERSION>());
      i.type = type_name(d.getInfo<CL_DEVICE_TYPE>());
      i.compute_units = d.getInfo<CL_DEVICE_MAX_COMPUTE_UNITS>();
      i.global_mem = d.getInfo<CL_DEVICE_GLOBAL_MEM_SIZE>();
      i.local_mem = d.getInfo<CL_DEVICE_LOCAL_MEM_SIZE>();
      i.max_alloc = d.getInfo<CL_DEVICE_MAX_MEM_ALLOC_SIZE>();
      i.max_work_group = d.getInfo<CL_DEVICE_MAX_WORK_GROUP_SIZE>();
      const std::string ext = d.getInfo<CL_DEVICE_EXTENSIONS>();
      i.fp64 = ext.find("cl_khr_fp64") != std::string::npos;
      out.push_back({d, i});
    }
  }
  if (out.empty()) throw DeviceError(kNoPlatform);
  return out;
}

bool matches(const DeviceInfo& i, const std::string& item) {
  const std::string l = lower(item);
  if (l == "all") return true;
  if (l == "cpu" || l == "gpu" || l == "accelerator") return i.type == l;
  return lower(i.name).find(l) != std::string::npos ||
         lower(i.platform).find(l) != std::string::npos ||
         lower(i.vendor).find(l) != std::string::npos;
}

}  // namespace

std::string DeviceInfo::label() const { return name + " [" + platform + "]"; }

Device::Device(cl::Device device, DeviceInfo info) : device_(std::move(device)), info_(std::move(info)) {
  try {
    context_ = cl::Context(device_);
  } catch (const cl::Error& e) {
    throw_device_error(e, "creating a context on device " + std::to_string(info_.index) + " (" +
                              info_.label() + ")");
  }
}

cl::CommandQueue Device::make_queue(bool profiling) const {
  try {
    return cl::CommandQueue(context_, device_, profiling ? CL_QUEUE_PROFILING_ENABLE : 0);
  } catch (const cl::Error& e) {
    throw_device_error(e, "creating a command queue on " + info_.label());
  }
}

std::vector<DeviceInfo> enumerate_devices() {
  std::vector<DeviceInfo> out;
  for (auto& f : enumerate_all()) out.push_back(f.info);
  return out;
}

std::string effective_selector(const std::string& selector) {
  if (!selector.empty()) return selector;
  if (const char* env = std::getenv("BSDFMIX_DEVICE"); env && *env) return env;
  return "0";
}

std::vector<Device> select_devices(const std::string& selector) {
  const std::string sel = effective_selector(selector);
  auto all = enumerate_all();
  std::vector<bool> chosen(all.size(), false);
  std::stringstream ss(sel);
  std::string item;
  while (std::getline(ss, item, ',')) {
    item = trim(item);
    if (item.empty()) continue;
    bool any = false;
    const bool numeric = std::all_of(item.begin(), item.end(), [](unsigned char c) { return std::isdigit(c); });
    if (numeric) {
      const std::size_t idx = std::stoul(item);
      if (idx >= all.size())
        throw DeviceError("device selector '" + sel + "': index " + item + " out of range (" +
                          std::to_string(all.size()) + " device(s); see `bsdfmix devices`)");
      chosen[idx] = any = true;
    } else {
      for (std::size_t k = 0; k < all.size(); ++k)
        if (matches(all[k].info, item)) chosen[k] = any = true;
    }
    if (!any)
      throw DeviceError("device selector '" + sel + "': no device matches '" + item +
                        "' (see `bsdfmix devices`)");
  }
  std::vector<Device> out;
  for (std::size_t k = 0; k < all.size(); ++k)
    if (chosen[k]) out.emplace_back(all[k].device, all[k].info);
  if (out.empty()) throw DeviceError("device selector '" + sel + "' selects no device");
  return out;
}

}  // namespace bsdfmix
