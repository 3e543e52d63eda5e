// The one place the OpenCL C++ bindings are included, with the project's settings.
#pragma once

#ifndef CL_HPP_ENABLE_EXCEPTIONS
#define CL_HPP_ENABLE_EXCEPTIONS
#endif
#ifndef CL_HPP_TARGET_OPENCL_VERSION
#define CL_HPP_TARGET_OPENCL_VERSION 120
#endif
#ifndef CL_HPP_MINIMUM_OPENCL_VERSION
#define CL_HPP_MINIMUM_OPENCL_VERSION 120
#endif

#if defined(__GNUC__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wignored-attributes"
#pragma GCC diagnostic ignored "-Wdeprecated-declarations"
#endif
#include <CL/opencl.hpp>
#if defined(__GNUC__)
#pragma GCC diagnostic pop
#endif

#include <string>

namespace bsdfmix {

// "CL_OUT_OF_RESOURCES" for -5, and so on.
const char* cl_error_name(cl_int code);

// Turns a cl::Error into a DeviceError naming the call, the error and `context`.
[[noreturn]] void throw_device_error(const cl::Error& e, const std::string& context);

}  // namespace bsdfmix
