// Kernels with named arguments, and checked buffers.
#include "device/routine.hpp"

#include <algorithm>

#include "core/error.hpp"
#include "device/program.hpp"

namespace bsdfmix {

Routine::Routine(const cl::Program& program, const std::string& kernel) : name_(kernel) {
  try {
    kernel_ = cl::Kernel(program, kernel.c_str());
    const cl_uint n = kernel_.getInfo<CL_KERNEL_NUM_ARGS>();
    args_.reserve(n);
    for (cl_uint i = 0; i < n; ++i) {
      std::string a = kernel_.getArgInfo<CL_KERNEL_ARG_NAME>(i);
      while (!a.empty() && a.back() == '\0') a.pop_back();
      args_.push_back(a);
    }
    held_.resize(n);
  } catch (const cl::Error& e) {
    throw_device_error(e, "creating kernel " + kernel + " (its argument names need -cl-kernel-arg-info)");
  }
}

std::size_t Routine::index(const std::string& arg) const {
  const auto it = std::find(args_.begin(), args_.end(), arg);
  if (it == args_.end()) throw DeviceError("kernel " + name_ + " has no argument named '" + arg + "'");
  return static_cast<std::size_t>(it - args_.begin());
}

Routine& Routine::set_real(const std::string& arg, double value, bool fp64) {
  if (fp64) return set(arg, value);
  return set(arg, static_cast<float>(value));
}

void Routine::run(const cl::CommandQueue& queue, const cl::NDRange& global, const cl::NDRange& local) {
  launch(queue, kernel_, name_, global, local);
}

cl::Buffer device_buffer(const Device& device, const std::string& what, std::size_t bytes, cl_mem_flags flags,
                         const void* host) {
  if (!host) bytes = std::max<std::size_t>(bytes, 4);  // a buffer is never empty
  const std::uint64_t max_alloc = device.info().max_alloc;
  if (max_alloc && bytes > max_alloc)
    throw DeviceError("buffer " + what + " needs " + std::to_string(bytes) + " bytes; " + device.info().label() +
                      " allows at most " + std::to_string(max_alloc) + " in one allocation");
  try {
    return cl::Buffer(device.context(), host ? flags : (flags & ~static_cast<cl_mem_flags>(CL_MEM_COPY_HOST_PTR)), bytes,
                      const_cast<void*>(host));
  } catch (const cl::Error& e) {
    throw_device_error(e, "allocating buffer " + what + " (" + std::to_string(bytes) + " bytes) on " +
                              device.info().label());
  }
}

}  // namespace bsdfmix
