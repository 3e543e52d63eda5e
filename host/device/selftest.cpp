// A device self-test: kernels/selftest.cl against the CPU.
#include "device/selftest.hpp"

#include <cmath>
#include <cstddef>
#include <vector>

#include "device/program.hpp"
#include "device/routine.hpp"
#include "device/shapes.hpp"

namespace bsdfmix {

SelftestResult run_selftest(const Device& device, unsigned n) {
  constexpr std::size_t kGroups = 32;
  const std::size_t wgs = item_group_size(device.info());
  std::vector<float> x(n), y(n);
  for (unsigned i = 0; i < n; ++i) {
    x[i] = std::sin(0.001f * float(i)) + 0.5f;
    y[i] = std::cos(0.003f * float(i));
  }
  const float a = 1.75f;
  SelftestResult r;
  try {
    cl::Program program = build_program(device, "selftest", "-DWGS=" + std::to_string(wgs));
    cl::CommandQueue q = device.make_queue();
    // Plain buffers, not device_buffer's: the self-test proves that kernels run, whatever
    // largest allocation the device reports (oclgrind's gpu-like profile: 96 KiB).
    cl::Buffer bx(device.context(), CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, n * sizeof(float), x.data());
    cl::Buffer by(device.context(), CL_MEM_READ_WRITE | CL_MEM_COPY_HOST_PTR, n * sizeof(float), y.data());
    cl::Buffer bp(device.context(), CL_MEM_WRITE_ONLY, kGroups * sizeof(float));
    Routine axpy(program, "axpy");
    axpy.set("a", a).set("x", bx).set("y", by).set("n", cl_uint(n));
    axpy.run(q, cl::NDRange(item_global_size(n, wgs)));
    Routine ss(program, "sum_squares");
    ss.set("x", bx).set("n", cl_uint(n)).set("partial", bp);
    ss.run(q, cl::NDRange(wgs * kGroups), cl::NDRange(wgs));
    std::vector<float> y_dev(n), partial(kGroups);
    q.enqueueReadBuffer(by, CL_TRUE, 0, n * sizeof(float), y_dev.data());
    q.enqueueReadBuffer(bp, CL_TRUE, 0, kGroups * sizeof(float), partial.data());
    double sum_dev = 0, sum_cpu = 0;
    for (float p : partial) sum_dev += p;
    for (unsigned i = 0; i < n; ++i) {
      const float expect = a * x[i] + y[i];
      r.axpy_max_abs_error = std::max(r.axpy_max_abs_error, double(std::abs(y_dev[i] - expect)));
      sum_cpu += double(x[i]) * x[i];
    }
    r.sum_squares_rel_error = std::abs(sum_dev - sum_cpu) / sum_cpu;
  } catch (const cl::Error& e) {
    throw_device_error(e, "self-test on " + device.info().label());
  }
  return r;
}

}  // namespace bsdfmix
