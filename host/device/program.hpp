// The one compile entry point for OpenCL programs, cached per (context, device, options),
// and launches checked against the device's limits before they are enqueued.
#pragma once

#include <string>

#include "device/device.hpp"

namespace bsdfmix {

// The OpenCL C source of kernels/<name>.cl: embedded at build time, or read from
// $BSDFMIX_KERNEL_DIR/<name>.cl when that variable is set (for kernel development).
std::string kernel_source(const std::string& name);

// Builds kernels/<name>.cl for `device` with `options` plus the device defines
// (BSDFMIX_FP64 = 0/1, BSDFMIX_CPU = 0/1). Cached; thread-safe. On failure throws
// DeviceError carrying the build log.
cl::Program build_program(const Device& device, const std::string& name,
                          const std::string& options = "");

// The device defines build_program adds.
std::string device_defines(const DeviceInfo& info);

// Enqueues `kernel` after checking the launch: a local size over the device or
// kernel maximum, a global size not a multiple of the local size, or local memory
// over the device's each get their own DeviceError naming `name`.
void launch(const cl::CommandQueue& queue, const cl::Kernel& kernel, const std::string& name,
            const cl::NDRange& global, const cl::NDRange& local = cl::NullRange);

}  // namespace bsdfmix
