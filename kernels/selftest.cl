// A trivial kernel that proves a device compiles and runs OpenCL C: y = a * x + y,
// plus a per-work-group sum of squares, checked against the CPU by `bsdfmix devices --check`
// and tests/device_test.cpp.

#ifndef WGS
#define WGS 64
#endif

__kernel void axpy(const float a, __global const float* x, __global float* y, const uint n) {
  const uint i = get_global_id(0);
  if (i < n) y[i] = a * x[i] + y[i];
}

__kernel __attribute__((reqd_work_group_size(WGS, 1, 1)))
void sum_squares(__global const float* x, const uint n, __global float* partial) {
  __local float scratch[WGS];
  const uint lid = get_local_id(0);
  float acc = 0.0f;
  for (uint i = get_global_id(0); i < n; i += get_global_size(0)) acc += x[i] * x[i];
  scratch[lid] = acc;
  barrier(CLK_LOCAL_MEM_FENCE);
  for (uint s = WGS / 2; s > 0; s >>= 1) {
    if (lid < s) scratch[lid] += scratch[lid + s];
    barrier(CLK_LOCAL_MEM_FENCE);
  }
  if (lid == 0) partial[get_group_id(0)] = scratch[0];
}
