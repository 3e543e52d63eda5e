// A device self-test: the kernels of kernels/selftest.cl against the same arithmetic on the CPU.
#pragma once

#include <string>

#include "device/device.hpp"

namespace bsdfmix {

struct SelftestResult {
  double axpy_max_abs_error = 0;      // max |device - cpu| of y = a x + y
  double sum_squares_rel_error = 0;  // |device - cpu| / cpu of sum x^2
  bool ok() const { return axpy_max_abs_error <= 1e-6 && sum_squares_rel_error <= 1e-4; }
};

// Runs the self-test on `device` over n elements (deterministic data).
SelftestResult run_selftest(const Device& device, unsigned n = 100000);

}  // namespace bsdfmix
