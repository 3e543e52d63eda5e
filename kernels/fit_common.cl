// The shared part of the fitting programs (kernels/em.cl, l1.cl, amplitudes.cl): host/
// device/program.cpp puts it after kernels/common.cl and before each of them. The cell
// layout, the real type, the vector type and the fast math every fitting kernel uses.
//
// Batched: one launch serves P problems (a problem = one slice, one K, one restart).
// A problem's cells are split into G chunks of WG * CPW * VEC cells; work-group
// (g, p) handles chunk g of problem p. Each work-item walks CPW vectors of VEC
// consecutive cells (explicit SIMD across cells, so a CPU compiler vectorizes the
// per-component work without having to vectorize across work-items) and keeps the
// weighted sufficient statistics of every component in private accumulators: the
// N x K responsibilities never reach memory.
//
// Defines (the host passes them; the defaults build stand-alone):
//   K_MAX   largest K of the problems in the launch (arrays are sized by it)
//   VEC     cells per work-item vector: 16, 8, 4 or 1
//   WG      work-group size (1 on CPUs: the vector is the parallelism)
//   CPW     cell vectors per work-item per chunk
//   EM_FP64 1: statistics above the lane level, the M-step and the state in double
//   BSDFMIX_FP64 whether the device has cl_khr_fp64 (added by the host)
//   MAP     the plane of the Gaussians (include/bsdfmix/mixture.hpp, Map): 0 (theta, phi),
//           1 Lambert's disk (hemisphere), 2 the cylinder (sin theta, phi) (fiber)

#ifndef K_MAX
#define K_MAX 16
#endif
#ifndef VEC
#define VEC 16
#endif
#ifndef WG
#define WG 1
#endif
#ifndef CPW
#define CPW 32
#endif
#ifndef EM_FP64
#define EM_FP64 0
#endif
#ifndef MAP
#define MAP 0
#endif
#ifndef BSDFMIX_FP64
#define BSDFMIX_FP64 0
#endif

#if EM_FP64
#if !BSDFMIX_FP64
#error "EM_FP64 needs a device with cl_khr_fp64"
#endif
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
typedef double real_t;
#define R(x) (x)
// kernels/common.cl's phi wrap and lane sums in double: wrap_phi_d, sum_lanes16_d, ..
BSDFMIX_WRAP_PHI(double, _d, 3.14159265358979323846)
BSDFMIX_LANE_SUMS(double, _d)
#define wrap_phi_r wrap_phi_d
#else
typedef float real_t;
#define R(x) (x##f)
#define wrap_phi_r wrap_phi
#endif

// Statistics per component and their layout in a partial record of NSTAT values:
// q * K_MAX + k for q = 0..5 (S0, St, Sp, Stt, Stp, Spp), then the log-likelihood.
#define NSTAT (6 * K_MAX + 1)
#define LL_INDEX (6 * K_MAX)
// Component state (double or float): q * K_MAX + k for q = 0..5 (weight, mean theta,
// mean phi, s_tt, s_tp, s_pp).
#define NSTATE (6 * K_MAX)
// E-step constants (float): q * K_MAX + k for q = 0..5 (mean theta, mean phi, qa, qb, qc, c0);
// log2 of the weighted density is c0 + qa dt^2 + qb dt dp + qc dp^2.
#define NCONST (6 * K_MAX)

#define TWO_PI_F 6.283185307179586f
#define PI_F 3.14159265358979f
#define LOG2E_F 1.4426950408889634f
#define LN2_F 0.6931471805599453f
#define LN2_R R(0.6931471805599453)
#define TWO_PI_R R(6.283185307179586)

#if VEC == 16
typedef float16 floatv;
#define VINT int16
#define VLOADV vload16
#define LANES ((float16)(0.f, 1.f, 2.f, 3.f, 4.f, 5.f, 6.f, 7.f, 8.f, 9.f, 10.f, 11.f, 12.f, 13.f, 14.f, 15.f))
#elif VEC == 8
typedef float8 floatv;
#define VINT int8
#define VLOADV vload8
#define LANES ((float8)(0.f, 1.f, 2.f, 3.f, 4.f, 5.f, 6.f, 7.f))
#elif VEC == 4
typedef float4 floatv;
#define VINT int4
#define VLOADV vload4
#define LANES ((float4)(0.f, 1.f, 2.f, 3.f))
#elif VEC == 1
typedef float floatv;
#define VLOADV(i, p) ((p)[i])
#define LANES 0.f
#else
#error "VEC must be 16, 8, 4 or 1"
#endif
#define CAT_(a, b) a##b
#define CAT(a, b) CAT_(a, b)
#define AS_VINT CAT(as_, VINT)
#define AS_VFLOAT CAT(as_float, VEC)
// x rounded toward zero (two conversions; the floor builtin is a longer sequence on PoCL).
#if VEC == 1
#define TRUNC_V(x) ((float)(int)(x))
#else
#define TRUNC_V(x) CAT(convert_float, VEC)(CAT(convert_int, VEC)(x))
#endif

// Sum of the lanes of a vector, each lane converted to real_t first (kernels/common.cl's
// tree of vector adds, not a loop over lanes).
inline real_t hsum(floatv v) {
#if VEC == 1
  return (real_t)v;
#elif EM_FP64
  return CAT(CAT(sum_lanes, VEC), _d)(CAT(convert_double, VEC)(v));
#else
  return CAT(sum_lanes, VEC)(v);
#endif
}

// Coordinates of the cells c .. c + VEC - 1 of a row-major [theta][phi] grid,
// computed from the index (no coordinate arrays in memory). Exact for c < 2^24.
inline void cell_coords(uint c, float inv_nphi, float nphi, float theta0, float dtheta,
                        float phi0, float dphi, floatv* t, floatv* ph) {
  const floatv cf = (float)c + LANES;
  const floatv row = TRUNC_V((cf + 0.5f) * inv_nphi);  // floor: the argument is positive
  const floatv col = cf - row * nphi;
  *t = theta0 + row * dtheta;
  *ph = phi0 + col * dphi;
}

// Nearest-image phi difference, in [-pi, pi], for d in (-2 pi, 2 pi) (both angles
// wrapped): two compares and two selects, cheaper than a rounding on CPUs. Not
// common.cl's wrap_phi: a vector over cells, valid only on (-2 pi, 2 pi), and +-pi both
// kept (the nearest image of a difference of exactly pi is either).
inline floatv wrap_diff(floatv d) {
  d = select(d, d - TWO_PI_F, d > PI_F);
  return select(d, d + TWO_PI_F, d < -PI_F);
}

// 2^x for x <= 0, 0 below 2^-64: responsibilities that small (relative to the
// largest of the cell) are dropped, so that their products with weights and
// offsets never reach the denormal range (x86 CPUs slow down about 3x on
// denormals where flush-to-zero is not in effect). kernels/common.cl bsdfmix_exp2_in:
// no clamp, since the select drops every x below -64 (whatever the polynomial gave there).
#if VEC == 1
#define EXP2_V bsdfmix_exp2_in
#else
#define EXP2_V CAT(bsdfmix_exp2_in, VEC)
#endif
inline floatv exp2_neg(floatv x) {
  const floatv r = EXP2_V(x);
#if VEC == 1
  return x > -64.0f ? r : 0.0f;
#else
  return select((floatv)0.0f, r, x > -64.0f);
#endif
}

// log2(x) for normal positive x: the exponent from the bits, log2 of the mantissa
// m in [1, 2) from t = (m - 1) / (m + 1) in [0, 1/3] by the odd series of atanh,
// 2 / ln 2 (t + t^3/3 + ... + t^11/11) (absolute error < 2e-7). Inline: the builtin
// is a library call on some CPU compilers, and em_estep takes one per cell.
inline floatv log2_fast(floatv x) {
#if VEC == 1
  const int bits = as_int(x);
  const float e = (float)((bits >> 23) - 127);
  const float m = as_float((bits & 0x007FFFFF) | 0x3F800000);
#else
  const VINT bits = AS_VINT(x);
  const floatv e = CAT(convert_float, VEC)((bits >> 23) - 127);
  const floatv m = AS_VFLOAT((bits & 0x007FFFFF) | 0x3F800000);
#endif
  const floatv t = (m - 1.0f) / (m + 1.0f);
  const floatv t2 = t * t;
  floatv p = fma(t2, 0.0909090909f, 0.1111111111f);
  p = fma(p, t2, 0.1428571429f);
  p = fma(p, t2, 0.2f);
  p = fma(p, t2, 0.3333333333f);
  p = fma(p, t2, 1.0f);
  return fma(2.8853900817779268f * t, p, e);
}

// The first cell of vector `it` of work-item `lid` in chunk g: chunk g holds the cells
// g * WG * CPW * VEC onwards, its work-items' vectors interleaved.
inline uint chunk_cell(uint g, uint it, uint lid) {
  return g * (WG * CPW * VEC) + (it * WG + lid) * VEC;
}

// Cells (theta, phi) as points (x, y) of the map's plane (MAP; the header's to_map).
inline void map_point(floatv t, floatv ph, floatv* x, floatv* y) {
#if MAP == 1
  const floatv r = 2.f * sin(0.5f * t);
  *x = r * cos(ph);
  *y = r * sin(ph);
#elif MAP == 2
  *x = sin(t);
  *y = ph;
#else
  *x = t;
  *y = ph;
#endif
}

// A cell's area in the plane over dtheta dphi at its point (x, y): its solid angle's
// J(theta): sin theta = r sqrt(1 - r^2 / 4) on the disk, cos theta = sqrt(1 - x^2) on the
// cylinder; 1 on (theta, phi).
inline floatv plane_jacobian(floatv x, floatv y) {
#if MAP == 1
  const floatv r2 = fma(x, x, y * y);
  return sqrt(r2 * fmax(1.f - 0.25f * r2, 0.f));
#elif MAP == 2
  return sqrt(fmax(1.f - x * x, 0.f));
#else
  return (floatv)1.f;
#endif
}

// A slice grid as the kernels' grid arguments give it (n_phi as a float).
typedef struct {
  float inv_nphi, nphi, theta0, dtheta, phi0, dphi;
} slice_grid;

inline slice_grid make_grid(uint n_phi, float inv_nphi, float theta0, float dtheta, float phi0, float dphi) {
  const slice_grid grid = {inv_nphi, (float)n_phi, theta0, dtheta, phi0, dphi};
  return grid;
}

// The first cell of vector `it` of work-item `lid` in chunk g (chunk_cell), and the
// angles (theta, phi) of its VEC cells (cell_coords).
inline uint grid_cell_angles(const slice_grid* grid, uint g, uint it, uint lid, floatv* t, floatv* ph) {
  const uint c = chunk_cell(g, it, lid);
  cell_coords(c, grid->inv_nphi, grid->nphi, grid->theta0, grid->dtheta, grid->phi0, grid->dphi, t, ph);
  return c;
}

// The same with the cells as points of the map's plane (map_point).
inline uint grid_cell(const slice_grid* grid, uint g, uint it, uint lid, floatv* x, floatv* y) {
  floatv t, ph;
  const uint c = grid_cell_angles(grid, g, it, lid, &t, &ph);
  map_point(t, ph, x, y);
  return c;
}

// The offsets of cells (t, ph) from the mean of component j (cparams `cp`, laid out as
// NCONST): dt, and dp to the nearest phi image.
inline void component_offsets(__global const float* cp, int j, floatv t, floatv ph, floatv* dt, floatv* dp) {
  *dt = t - cp[0 * K_MAX + j];
  *dp = wrap_diff(ph - cp[1 * K_MAX + j]);
}

// The phi offset of image `img` (whole turns) of a nearest-image offset d0.
inline floatv image_offset(floatv d0, int img) { return d0 + (float)img * TWO_PI_F; }

// The Gaussian quadratic of component j: log2 of its weighted density at offsets (dt, dp)
// from its mean, c0 + qa dt^2 + qb dt dp + qc dp^2.
inline floatv component_log2(__global const float* cp, int j, floatv dt, floatv dp) {
  return fma(dt, fma((floatv)cp[2 * K_MAX + j], dt, cp[3 * K_MAX + j] * dp),
             fma((floatv)cp[4 * K_MAX + j], dp * dp, (floatv)cp[5 * K_MAX + j]));
}

// Writes the E-step constants of component k of a problem from its state.
inline void component_constants(__global const real_t* st, __global float* cp, int k) {
  const real_t w = st[0 * K_MAX + k], mt = st[1 * K_MAX + k], mp = st[2 * K_MAX + k];
  const real_t stt = st[3 * K_MAX + k], stp = st[4 * K_MAX + k], spp = st[5 * K_MAX + k];
  const real_t det = stt * spp - stp * stp;
  const real_t l2e = R(1.4426950408889634);
  cp[0 * K_MAX + k] = (float)mt;
  cp[1 * K_MAX + k] = (float)mp;
  cp[2 * K_MAX + k] = (float)(-R(0.5) * l2e * spp / det);
  cp[3 * K_MAX + k] = (float)(l2e * stp / det);
  cp[4 * K_MAX + k] = (float)(-R(0.5) * l2e * stt / det);
  cp[5 * K_MAX + k] = (float)(log2(w) - log2(TWO_PI_R) - R(0.5) * log2(det));
}

#if WG > 1
// The sum of every work-item's `v` over the work-group (a tree through `scratch`, WG values
// of local memory), returned to every work-item; `scratch` is free again on return.
inline real_t group_sum(real_t v, __local real_t* scratch) {
  const uint lid = get_local_id(0);
  scratch[lid] = v;
  barrier(CLK_LOCAL_MEM_FENCE);
  for (uint span = WG / 2; span > 0; span >>= 1) {
    if (lid < span) scratch[lid] += scratch[lid + span];
    barrier(CLK_LOCAL_MEM_FENCE);
  }
  const real_t total = scratch[0];
  barrier(CLK_LOCAL_MEM_FENCE);
  return total;
}
#endif

// Writes a work-group's sums to `out`: per component j the nq sums a[stride j + q] (the
// rest of a component's stride is the caller's scratch) at q * K_MAX + j, then `last`
// at nq * K_MAX; with WG > 1 each summed over the work-group through `scratch` (WG values
// of local memory).
inline void write_sums(const floatv* a, const int stride, const floatv last, const int k, const int nq,
                       __global real_t* out, __local real_t* scratch) {
#if WG == 1
  for (int j = 0; j < k; ++j)
    for (int q = 0; q < nq; ++q) out[q * K_MAX + j] = hsum(a[stride * j + q]);
  out[nq * K_MAX] = hsum(last);
#else
  const uint lid = get_local_id(0);
  for (int q = 0; q <= nq * k; ++q) {
    const int j = q % k;
    const int which = q / k;
    const real_t total = group_sum(hsum(which < nq ? a[stride * j + which] : last), scratch);
    if (lid == 0) out[which < nq ? which * K_MAX + j : nq * K_MAX] = total;
  }
#endif
}
