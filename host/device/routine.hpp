// One launch path for every device routine: a kernel whose arguments are set by the names
// its OpenCL C source gives them, and the buffers a batch uploads, checked against the
// device's largest single allocation.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "device/device.hpp"

namespace bsdfmix {

// A kernel of a program built by build_program (which builds with -cl-kernel-arg-info).
class Routine {
 public:
  Routine(const cl::Program& program, const std::string& kernel);

  // Sets argument `arg` (its name in the kernel's source); DeviceError naming the kernel
  // and the argument when the kernel has no such argument.
  template <class T>
  Routine& set(const std::string& arg, const T& value) {
    kernel_.setArg(static_cast<cl_uint>(index(arg)), value);
    return *this;
  }
  // A buffer argument is also kept by the routine until another buffer is set there or the
  // routine is destroyed: OpenCL does not keep an argument's memory object alive, so a
  // buffer made for the call stays valid.
  Routine& set(const std::string& arg, const cl::Buffer& buffer) {
    const std::size_t i = index(arg);
    kernel_.setArg(static_cast<cl_uint>(i), buffer);
    held_[i] = buffer;
    return *this;
  }
  // A real_t argument: double when the program was built for fp64, else float.
  Routine& set_real(const std::string& arg, double value, bool fp64);

  // Checked launch (device/program.hpp launch) under the kernel's name.
  void run(const cl::CommandQueue& queue, const cl::NDRange& global,
           const cl::NDRange& local = cl::NullRange);

  const std::string& name() const { return name_; }
  const std::vector<std::string>& arguments() const { return args_; }

 private:
  std::size_t index(const std::string& arg) const;
  cl::Kernel kernel_;
  std::string name_;
  std::vector<std::string> args_;
  std::vector<cl::Buffer> held_;  // per argument: the buffer last set there
};

// A device buffer of `bytes` (at least 1) with `flags`, copied from `host` when it is not
// null. A size over the device's largest single allocation is a DeviceError naming `what`,
// the sizes and the device (the engines split their batches so that it never happens).
cl::Buffer device_buffer(const Device& device, const std::string& what, std::size_t bytes,
                         cl_mem_flags flags, const void* host = nullptr);

// A read-only copy of `v` on the device.
template <class T>
cl::Buffer upload(const Device& device, const std::string& what, const std::vector<T>& v) {
  return device_buffer(device, what, v.size() * sizeof(T), CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR,
                       v.empty() ? nullptr : v.data());
}

// Reads the whole of `out` (its size decides the bytes) from `buffer`.
template <class T>
void download(const cl::CommandQueue& queue, const cl::Buffer& buffer, std::vector<T>& out, bool blocking) {
  if (!out.empty()) queue.enqueueReadBuffer(buffer, blocking ? CL_TRUE : CL_FALSE, 0, out.size() * sizeof(T), out.data());
}

}  // namespace bsdfmix
