// The one compile entry point for OpenCL programs, cached per device (Device::programs) and options,
// and launches checked against the device's limits before they are enqueued.
#pragma once

#include <string>

#include "device/device.hpp"

namespace bsdfmix {

// The text of the file kernels/<name>.cl: embedded at build time, or read from
// $BSDFMIX_KERNEL_DIR/<name>.cl when that variable is set (for kernel development).
std::string kernel_file(const std::string& name);

// The OpenCL C source of the program kernels/<name>.cl, as build_program compiles it:
// kernels/common.cl (the primitives every program shares: Philox, the phi wrap, the lane
// sums, 2^x), then kernels/fit_common.cl for the fitting programs (em, l1, amplitudes),
// then the file itself, each file's lines numbered from 1 again. All come from the same
// place (kernel_file). DeviceError for "common" and "fit_common", no programs of their own.
std::string kernel_source(const std::string& name);

// kernels/common.cl (and kernels/fit_common.cl for a fitting program), then `text`
// (lines numbered as <name>.cl).
std::string program_text(const std::string& name, const std::string& text);

// Builds kernels/<name>.cl (kernel_source) for `device` with `options` plus the device
// defines (BSDFMIX_FP64 = 0/1, BSDFMIX_CPU = 0/1). Cached; thread-safe. On failure throws
// DeviceError carrying the build log.
cl::Program build_program(const Device& device, const std::string& name,
                          const std::string& options = "");

// The same for a program given as text (program_text(name, text)), named `name` in errors:
// small kernels of tests and tools that use kernels/common.cl. Cached by the text's hash.
cl::Program build_program_text(const Device& device, const std::string& name, const std::string& text,
                               const std::string& options = "");

// The device defines build_program adds.
std::string device_defines(const DeviceInfo& info);

// Enqueues `kernel` after checking the launch: a local size over the device or
// kernel maximum, a global size not a multiple of the local size, or local memory
// over the device's each get their own DeviceError naming `name`.
void launch(const cl::CommandQueue& queue, const cl::Kernel& kernel, const std::string& name,
            const cl::NDRange& global, const cl::NDRange& local = cl::NullRange);

}  // namespace bsdfmix
