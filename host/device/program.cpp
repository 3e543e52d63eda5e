// The one compile entry point for OpenCL programs (kernels/common.cl in front of each),
// and checked launches.
#include "device/program.hpp"

#include <algorithm>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <sstream>
#include <utility>
#include <vector>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "core/hash.hpp"

namespace bsdfmix {

namespace embedded {
const std::vector<std::pair<std::string, std::string>>& kernel_sources();
}

namespace {

constexpr const char* kCommon = "common";

// The files put between kernels/common.cl and a program's own file, and the programs that
// need them; such a file is no program of its own.
struct Prelude {
  const char* file;
  std::vector<std::string> programs;
};
const std::vector<Prelude>& preludes() {
  static const std::vector<Prelude> list = {{"fit_common", {"em", "l1", "amplitudes"}}};
  return list;
}

// Builds the source of `label` ("kernels/em.cl") for `device`, cached under `key_name` and
// the options.
cl::Program build_cached(const Device& device, const std::string& label, const std::string& key_name,
                         const std::string& options, const std::function<std::string()>& source_of) {
  ProgramCache& cache = device.programs();
  const std::string full = "-cl-std=CL1.2 -cl-kernel-arg-info" + device_defines(device.info()) + " " + options;
  const std::pair<std::string, std::string> key{key_name, full};
  {
    std::lock_guard<std::mutex> lock(cache.mutex);
    if (auto it = cache.programs.find(key); it != cache.programs.end()) return it->second;
  }
  const std::string source = source_of();
  cl::Program program;
  try {
    program = cl::Program(device.context(), source);
  } catch (const cl::Error& e) {
    throw_device_error(e, "creating program " + label);
  }
  try {
    program.build(std::vector<cl::Device>{device.cl_device()}, full.c_str());
  } catch (const cl::Error& e) {
    std::string log;
    try {
      log = program.getBuildInfo<CL_PROGRAM_BUILD_LOG>(device.cl_device());
    } catch (const cl::Error&) {
      log = "(no build log)";
    }
    while (!log.empty() && (log.back() == '\n' || log.back() == '\0')) log.pop_back();
    throw DeviceError("building " + label + " for " + device.info().label() +
                      " with options '" + full + "' failed with " + cl_error_name(e.err()) +
                      "; build log:\n" + log);
  }
  std::lock_guard<std::mutex> lock(cache.mutex);
  cache.programs.emplace(key, program);
  return program;
}

}  // namespace

std::string kernel_file(const std::string& name) {
  if (const char* dir = std::getenv("BSDFMIX_KERNEL_DIR"); dir && *dir) {
    const std::string path = std::string(dir) + "/" + name + ".cl";
    const std::optional<std::string> text = read_text(path);
    if (!text) throw DeviceError("BSDFMIX_KERNEL_DIR: cannot read kernel source " + path);
    return *text;
  }
  for (const auto& [stem, text] : embedded::kernel_sources())
    if (stem == name) return text;
  throw DeviceError("no embedded kernel named '" + name + "'");
}

std::string program_text(const std::string& name, const std::string& text) {
  // "#line 1" restarts the count, so that the build log gives the lines of each file itself.
  std::string out = kernel_file(kCommon);
  for (const Prelude& p : preludes())
    if (std::find(p.programs.begin(), p.programs.end(), name) != p.programs.end())
      out += "\n#line 1 \"" + std::string(p.file) + ".cl\"\n" + kernel_file(p.file);
  return out + "\n#line 1 \"" + name + ".cl\"\n" + text;
}

std::string kernel_source(const std::string& name) {
  if (name == kCommon)
    throw DeviceError("kernels/common.cl is put in front of every program, not built on its own");
  for (const Prelude& p : preludes())
    if (name == p.file)
      throw DeviceError("kernels/" + name + ".cl is put in front of other programs, not built on its own");
  const std::string own = kernel_file(name);
  return program_text(name, own);
}

std::string device_defines(const DeviceInfo& info) {
  return std::string(" -DBSDFMIX_FP64=") + (info.fp64 ? "1" : "0") +
         " -DBSDFMIX_CPU=" + (info.is_cpu() ? "1" : "0");
}

cl::Program build_program(const Device& device, const std::string& name, const std::string& options) {
  return build_cached(device, "kernels/" + name + ".cl", name, options, [&] { return kernel_source(name); });
}

cl::Program build_program_text(const Device& device, const std::string& name, const std::string& text,
                               const std::string& options) {
  const std::string key = "text " + name + " " + Hash64().update(text.data(), text.size()).hex();
  return build_cached(device, "program " + name + " (kernels/common.cl and its text)", key, options,
                      [&] { return program_text(name, text); });
}

void launch(const cl::CommandQueue& queue, const cl::Kernel& kernel, const std::string& name,
            const cl::NDRange& global, const cl::NDRange& local) {
  try {
    const cl::Device dev = queue.getInfo<CL_QUEUE_DEVICE>();
    const std::size_t dims = global.dimensions();
    if (local.dimensions() != 0) {
      if (local.dimensions() != dims)
        throw DeviceError("kernel " + name + ": local range has " + std::to_string(local.dimensions()) +
                          " dimensions, global " + std::to_string(dims));
      std::size_t local_total = 1;
      for (std::size_t d = 0; d < dims; ++d) {
        local_total *= local[d];
        if (local[d] == 0 || global[d] % local[d] != 0)
          throw DeviceError("kernel " + name + ": global size " + std::to_string(global[d]) +
                            " in dimension " + std::to_string(d) + " is not a multiple of local size " +
                            std::to_string(local[d]));
      }
      const std::size_t dev_max = dev.getInfo<CL_DEVICE_MAX_WORK_GROUP_SIZE>();
      const std::size_t ker_max = kernel.getWorkGroupInfo<CL_KERNEL_WORK_GROUP_SIZE>(dev);
      if (local_total > dev_max || local_total > ker_max)
        throw DeviceError("kernel " + name + ": local size " + std::to_string(local_total) +
                          " exceeds the maximum work-group size (device " + std::to_string(dev_max) +
                          ", kernel " + std::to_string(ker_max) + ")");
    }
    const cl_ulong local_used = kernel.getWorkGroupInfo<CL_KERNEL_LOCAL_MEM_SIZE>(dev);
    const cl_ulong local_avail = dev.getInfo<CL_DEVICE_LOCAL_MEM_SIZE>();
    if (local_used > local_avail)
      throw DeviceError("kernel " + name + ": needs " + std::to_string(local_used) +
                        " bytes of local memory, the device has " + std::to_string(local_avail));
    queue.enqueueNDRangeKernel(kernel, cl::NullRange, global, local);
  } catch (const cl::Error& e) {
    throw_device_error(e, "launching kernel " + name);
  }
}

}  // namespace bsdfmix
