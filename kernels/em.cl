// Weighted EM for 2D Gaussian mixtures over (theta, phi) cell grids, phi periodic.
// See docs/em.md for the equations; host/fit/em_reference.cpp is the CPU reference.
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
  const floatv row = floor((cf + 0.5f) * inv_nphi);
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
// denormals where flush-to-zero is not in effect). x = n + f with n the nearest
// integer (by the 1.5 * 2^23 rounding trick: two adds instead of a conversion),
// f in [-1/2, 1/2]; 2^f by its degree-6 Taylor polynomial (relative error < 2e-7),
// 2^n added to the exponent bits.
#define ROUND_MAGIC 12582912.0f
#define ROUND_MAGIC_BITS 0x4B400000
inline floatv exp2_neg(floatv x) {
  x = fmax(x, -126.0f);
  const floatv t = x + ROUND_MAGIC;
  const floatv f = x - (t - ROUND_MAGIC);
#if VEC == 1
  const int n = as_int(t) - ROUND_MAGIC_BITS;
#else
  const VINT n = AS_VINT(t) - ROUND_MAGIC_BITS;
#endif
  floatv p = fma(f, 1.5403530e-4f, 1.3333558e-3f);
  p = fma(p, f, 9.6181291e-3f);
  p = fma(p, f, 5.5504109e-2f);
  p = fma(p, f, 2.4022651e-1f);
  p = fma(p, f, 6.9314718e-1f);
  p = fma(p, f, 1.0f);
#if VEC == 1
  const float r = as_float(as_int(p) + (n << 23));
  return x > -64.0f ? r : 0.0f;
#else
  const floatv r = AS_VFLOAT(AS_VINT(p) + (n << 23));
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

// Writes a work-group's sums to `out`: per component j the nq sums a[(nq + 1) j + q] (the
// last slot of a component's stride is the caller's scratch) at q * K_MAX + j, then `last`
// at nq * K_MAX; with WG > 1 each summed over the work-group through `scratch` (WG values
// of local memory).
inline void write_sums(const floatv* a, const floatv last, const int k, const int nq, __global real_t* out,
                       __local real_t* scratch) {
  const int stride = nq + 1;
#if WG == 1
  for (int j = 0; j < k; ++j)
    for (int q = 0; q < nq; ++q) out[q * K_MAX + j] = hsum(a[stride * j + q]);
  out[nq * K_MAX] = hsum(last);
#else
  const uint lid = get_local_id(0);
  for (int q = 0; q <= nq * k; ++q) {
    const int j = q % k;
    const int which = q / k;
    scratch[lid] = hsum(which < nq ? a[stride * j + which] : last);
    barrier(CLK_LOCAL_MEM_FENCE);
    for (uint span = WG / 2; span > 0; span >>= 1) {
      if (lid < span) scratch[lid] += scratch[lid + span];
      barrier(CLK_LOCAL_MEM_FENCE);
    }
    if (lid == 0) out[which < nq ? which * K_MAX + j : nq * K_MAX] = scratch[0];
    barrier(CLK_LOCAL_MEM_FENCE);
  }
#endif
}

// EM's statistics: the six sums a[7 j + q], then `last` at LL_INDEX.
inline void write_partials(const floatv* a, const floatv last, const int k, __global real_t* out,
                           __local real_t* scratch) {
  write_sums(a, last, k, 6, out, scratch);
}

// Status per problem: [2p] = 0 running, 1 done, 2 failed; [2p + 1] = iterations (M-steps) done.

__kernel void em_constants(const uint n_problems, __global const int* prob_k,
                           __global const real_t* state, __global float* cparams) {
  const uint p = get_global_id(0);
  if (p >= n_problems) return;
  const int k = prob_k[p];
  for (int j = 0; j < k; ++j) component_constants(state + p * NSTATE, cparams + p * NCONST, j);
}

// E-step fused with the accumulation of the weighted sufficient statistics, centred
// on the current means (phi offsets to the nearest image), and the weighted
// log-likelihood (in log2 units). Global size (G * WG, P), local (WG, 1).
__kernel __attribute__((reqd_work_group_size(WG, 1, 1)))
void em_estep(const uint slice_stride, const uint n_phi, const float inv_nphi,
              const float theta0, const float dtheta, const float phi0, const float dphi,
              __global const float* restrict weights, __global const int* restrict prob_slice,
              __global const int* restrict prob_k, __global const int* restrict status,
              __global const float* restrict cparams, __global real_t* restrict partials) {
  const uint p = get_group_id(1);
  const uint g = get_group_id(0);
  const uint G = get_num_groups(0);
  const uint lid = get_local_id(0);
  if (status[2 * p] != 0) return;
  const int k = prob_k[p];
  __global const float* cp = cparams + p * NCONST;
  __global const float* w = weights + (uint)prob_slice[p] * slice_stride;
  const float nphi = (float)n_phi;

  // Per component: the six accumulators and the E-step scratch value, interleaved
  // (separate arrays of K_MAX vectors would sit 4 KiB apart and alias in the L1 cache).
  floatv a[7 * K_MAX];
#define A0(j) a[7 * (j) + 0]
#define A1(j) a[7 * (j) + 1]
#define A2(j) a[7 * (j) + 2]
#define A3(j) a[7 * (j) + 3]
#define A4(j) a[7 * (j) + 4]
#define A5(j) a[7 * (j) + 5]
#define E(j) a[7 * (j) + 6]
  for (int j = 0; j < k; ++j) A0(j) = A1(j) = A2(j) = A3(j) = A4(j) = A5(j) = (floatv)0.f;
  floatv ll = (floatv)0.f;

  const uint base = g * (WG * CPW * VEC);
  for (uint it = 0; it < CPW; ++it) {
    const uint c = base + (it * WG + lid) * VEC;
    const floatv wv = VLOADV(0, w + c);
    floatv t, ph;
    cell_coords(c, inv_nphi, nphi, theta0, dtheta, phi0, dphi, &t, &ph);
    floatv m = (floatv)(-INFINITY);
    for (int j = 0; j < k; ++j) {
      const floatv dt = t - cp[0 * K_MAX + j];
      const floatv dp = wrap_diff(ph - cp[1 * K_MAX + j]);
      const floatv ej = fma(dt, fma((floatv)cp[2 * K_MAX + j], dt, cp[3 * K_MAX + j] * dp),
                            fma((floatv)cp[4 * K_MAX + j], dp * dp, (floatv)cp[5 * K_MAX + j]));
      E(j) = ej;
      m = select(m, ej, ej > m);
    }
    floatv s = (floatv)0.f;
    for (int j = 0; j < k; ++j) {
      const floatv r = exp2_neg(E(j) - m);
      E(j) = r;
      s += r;
    }
    const floatv f = wv / s;
    ll = fma(wv, m + log2_fast(s), ll);
    for (int j = 0; j < k; ++j) {
      const floatv dt = t - cp[0 * K_MAX + j];
      const floatv dp = wrap_diff(ph - cp[1 * K_MAX + j]);
      const floatv rw = f * E(j);
      const floatv rwt = rw * dt, rwp = rw * dp;
      A0(j) += rw;
      A1(j) += rwt;
      A2(j) += rwp;
      A3(j) = fma(rwt, dt, A3(j));
      A4(j) = fma(rwt, dp, A4(j));
      A5(j) = fma(rwp, dp, A5(j));
    }
  }

  __local real_t scratch[WG];
  write_partials(a, ll, k, partials + (p * G + g) * NSTAT, scratch);
}

// Sum over the G chunks of one statistic: plain in double, compensated (Kahan) in float.
inline real_t sum_chunks(__global const real_t* partials, uint p, uint G, int index) {
  real_t s = R(0.0);
#if EM_FP64
  for (uint g = 0; g < G; ++g) s += partials[(p * G + g) * NSTAT + index];
#else
  real_t comp = R(0.0);
  for (uint g = 0; g < G; ++g) {
    const real_t y = partials[(p * G + g) * NSTAT + index] - comp;
    const real_t t = s + y;
    comp = (t - s) - y;
    s = t;
  }
#endif
  return s;
}

// Raises the eigenvalues of the covariance [a b; b c] to at least f (the
// covariance floor), keeping the eigenvectors: components wider than the floor
// are untouched, a component cannot collapse onto one cell.
inline void floor_covariance(real_t* a, real_t* b, real_t* c, const real_t f) {
  const real_t half_tr = R(0.5) * (*a + *c);
  const real_t disc = sqrt(R(0.25) * (*a - *c) * (*a - *c) + *b * *b);
  const real_t l1 = half_tr + disc, l2 = half_tr - disc;
  if (l2 >= f) return;
  if (*b == R(0.0)) {
    *a = fmax(*a, f);
    *c = fmax(*c, f);
    return;
  }
  real_t vx = l1 - *c, vy = *b;
  const real_t n = sqrt(vx * vx + vy * vy);
  vx /= n;
  vy /= n;
  const real_t m1 = fmax(l1, f), m2 = f;
  *a = m1 * vx * vx + m2 * vy * vy;
  *b = (m1 - m2) * vx * vy;
  *c = m1 * vy * vy + m2 * vx * vx;
}

// M-step, one work-item per problem: reduces the chunk statistics, tests
// convergence on the log-likelihood of the current state, updates the state
// (weights, means with phi wrapped, covariances floored), re-seeds empty
// components by splitting the heaviest one, and writes the E-step constants.
__kernel void em_mstep(const uint n_problems, const uint G, const int iter, const int max_iter,
                       const real_t tol, const real_t cov_floor, const real_t min_weight,
                       __global const int* prob_k, __global int* status, __global real_t* state,
                       __global real_t* lprev, __global const real_t* partials,
                       __global float* cparams) {
  const uint p = get_global_id(0);
  if (p >= n_problems) return;
  if (status[2 * p] != 0) return;
  const int k = prob_k[p];
  __global real_t* st = state + p * NSTATE;

  const real_t L = LN2_R * sum_chunks(partials, p, G, LL_INDEX);
  if (!isfinite(L)) {
    status[2 * p] = 2;
    status[2 * p + 1] = iter - 1;
    return;
  }
  if (iter >= 2 && tol > R(0.0) && fabs(L - lprev[p]) <= tol * fmax(R(1.0), fabs(L))) {
    status[2 * p] = 1;
    status[2 * p + 1] = iter - 1;
    lprev[p] = L;
    return;
  }
  lprev[p] = L;

  real_t total = R(0.0);
  for (int j = 0; j < k; ++j) total += sum_chunks(partials, p, G, 0 * K_MAX + j);
  if (!(total > R(0.0)) || !isfinite(total)) {
    status[2 * p] = 2;
    status[2 * p + 1] = iter - 1;
    return;
  }
  bool empty[K_MAX];
  for (int j = 0; j < k; ++j) {
    const real_t s0 = sum_chunks(partials, p, G, 0 * K_MAX + j);
    empty[j] = !(s0 > min_weight * total);
    if (empty[j]) continue;
    const real_t dt = sum_chunks(partials, p, G, 1 * K_MAX + j) / s0;
    const real_t dp = sum_chunks(partials, p, G, 2 * K_MAX + j) / s0;
    real_t ctt = sum_chunks(partials, p, G, 3 * K_MAX + j) / s0 - dt * dt;
    real_t ctp = sum_chunks(partials, p, G, 4 * K_MAX + j) / s0 - dt * dp;
    real_t cpp = sum_chunks(partials, p, G, 5 * K_MAX + j) / s0 - dp * dp;
    ctt = fmax(ctt, R(0.0));
    cpp = fmax(cpp, R(0.0));
    const real_t lim = sqrt(ctt * cpp);
    ctp = fmin(fmax(ctp, -lim), lim);
    st[0 * K_MAX + j] = s0 / total;
    st[1 * K_MAX + j] += dt;
    st[2 * K_MAX + j] = wrap_phi_r(st[2 * K_MAX + j] + dp);
    floor_covariance(&ctt, &ctp, &cpp, cov_floor);
    st[3 * K_MAX + j] = ctt;
    st[4 * K_MAX + j] = ctp;
    st[5 * K_MAX + j] = cpp;
  }
  // Re-seed each empty component (in index order) by splitting the heaviest
  // non-empty one along its principal axis: means +- half a standard deviation,
  // weight halved, covariance kept.
  for (int j = 0; j < k; ++j) {
    if (!empty[j]) continue;
    int h = -1;
    for (int i = 0; i < k; ++i)
      if (!empty[i] && (h < 0 || st[0 * K_MAX + i] > st[0 * K_MAX + h])) h = i;
    if (h < 0) {
      status[2 * p] = 2;
      status[2 * p + 1] = iter - 1;
      return;
    }
    const real_t a = st[3 * K_MAX + h], b = st[4 * K_MAX + h], c = st[5 * K_MAX + h];
    const real_t half_tr = R(0.5) * (a + c);
    const real_t disc = sqrt(R(0.25) * (a - c) * (a - c) + b * b);
    const real_t lambda = half_tr + disc;
    real_t vx, vy;
    if (fabs(b) > R(0.0)) {
      vx = lambda - c;
      vy = b;
    } else if (a >= c) {
      vx = R(1.0);
      vy = R(0.0);
    } else {
      vx = R(0.0);
      vy = R(1.0);
    }
    const real_t norm = sqrt(vx * vx + vy * vy);
    const real_t step = R(0.5) * sqrt(lambda) / norm;
    const real_t mt = st[1 * K_MAX + h], mp = st[2 * K_MAX + h];
    st[1 * K_MAX + j] = mt + step * vx;
    st[2 * K_MAX + j] = wrap_phi_r(mp + step * vy);
    st[1 * K_MAX + h] = mt - step * vx;
    st[2 * K_MAX + h] = wrap_phi_r(mp - step * vy);
    st[0 * K_MAX + h] *= R(0.5);
    st[0 * K_MAX + j] = st[0 * K_MAX + h];
    st[3 * K_MAX + j] = a;
    st[4 * K_MAX + j] = b;
    st[5 * K_MAX + j] = c;
    empty[j] = false;
  }
  real_t wsum = R(0.0);
  for (int j = 0; j < k; ++j) wsum += st[0 * K_MAX + j];
  for (int j = 0; j < k; ++j) st[0 * K_MAX + j] /= wsum;
  for (int j = 0; j < k; ++j) component_constants(st, cparams + p * NCONST, j);
  status[2 * p + 1] = iter;
  if (iter >= max_iter) status[2 * p] = 1;
}

// The weighted log-likelihood (natural log) of the final state with the exact
// periodic density: every component summed over the phi images m = -1, 0, 1.
// One partial per chunk; the host adds them. Same grid as em_estep.
__kernel __attribute__((reqd_work_group_size(WG, 1, 1)))
void em_loglik(const uint slice_stride, const uint n_phi, const float inv_nphi,
               const float theta0, const float dtheta, const float phi0, const float dphi,
               __global const float* restrict weights, __global const int* restrict prob_slice,
               __global const int* restrict prob_k, __global const int* restrict status,
               __global const float* restrict cparams, __global real_t* restrict partials) {
  const uint p = get_group_id(1);
  const uint g = get_group_id(0);
  const uint G = get_num_groups(0);
  const uint lid = get_local_id(0);
  if (status[2 * p] == 2) return;
  const int k = prob_k[p];
  __global const float* cp = cparams + p * NCONST;
  __global const float* w = weights + (uint)prob_slice[p] * slice_stride;
  const float nphi = (float)n_phi;
  floatv ll = (floatv)0.f;
  const uint base = g * (WG * CPW * VEC);
  for (uint it = 0; it < CPW; ++it) {
    const uint c = base + (it * WG + lid) * VEC;
    const floatv wv = VLOADV(0, w + c);
    floatv t, ph;
    cell_coords(c, inv_nphi, nphi, theta0, dtheta, phi0, dphi, &t, &ph);
    floatv m = (floatv)(-INFINITY);
    for (int j = 0; j < k; ++j) {
      const floatv dt = t - cp[0 * K_MAX + j];
      const floatv d0 = wrap_diff(ph - cp[1 * K_MAX + j]);
      for (int img = -1; img <= 1; ++img) {
        const floatv dp = d0 + (float)img * TWO_PI_F;
        const floatv ej = fma(dt, fma((floatv)cp[2 * K_MAX + j], dt, cp[3 * K_MAX + j] * dp),
                              fma((floatv)cp[4 * K_MAX + j], dp * dp, (floatv)cp[5 * K_MAX + j]));
        m = fmax(m, ej);
      }
    }
    floatv s = (floatv)0.f;
    for (int j = 0; j < k; ++j) {
      const floatv dt = t - cp[0 * K_MAX + j];
      const floatv d0 = wrap_diff(ph - cp[1 * K_MAX + j]);
      for (int img = -1; img <= 1; ++img) {
        const floatv dp = d0 + (float)img * TWO_PI_F;
        const floatv ej = fma(dt, fma((floatv)cp[2 * K_MAX + j], dt, cp[3 * K_MAX + j] * dp),
                              fma((floatv)cp[4 * K_MAX + j], dp * dp, (floatv)cp[5 * K_MAX + j]));
        s += exp2(ej - m);
      }
    }
    ll += wv * (m + log2(s));
  }
#if WG == 1
  partials[p * G + g] = LN2_R * hsum(ll);
#else
  __local real_t scratch[WG];
  scratch[lid] = hsum(ll);
  barrier(CLK_LOCAL_MEM_FENCE);
  for (uint span = WG / 2; span > 0; span >>= 1) {
    if (lid < span) scratch[lid] += scratch[lid + span];
    barrier(CLK_LOCAL_MEM_FENCE);
  }
  if (lid == 0) partials[p * G + g] = LN2_R * scratch[0];
#endif
}

// The refinement's objective, the smoothed L1 error of a mixture as the stand-in for its
// slice plus kl times the Kullback-Leibler divergence of the mixture from the slice, and
// the statistics of its gradient (host/fit/l1_refine.cpp, docs/fitting.md "L1
// refinement"), with problem p's weights kl = prob_weights[2 p] and rgb_weight =
// prob_weights[2 p + 1]. Per cell: m = area * sum_j sum_images pi_j N_j (the weights of a slice
// sum to 1), d = w - m, rho = sqrt(d^2 + eps^2), s = d / rho + kl * w / m. Per chunk:
// sum of rho + kl * w log(w / m) at the objective's index, and per component the sums of
// s * pi_j N_j times (1, dt, dp, dt^2, dt dp, dp^2), each image with its own offset dp
// from the mean. prob_images[p * K_MAX + j]: the phi images on each side
// that component j needs. Cells past n_cells (the padding) take no part. Global size
// (G * WG, P), local (WG, 1).
//
// With L1_CH = 3 the R, G, B channels join the objective (docs/fitting.md, "Colour and
// energy"): channel c of the slice is `channels + prob_slice[p] * 3 * slice_stride + c *
// slice_stride` (integrand weights of any sign, normalized by the host), its stand-in
// m_c = area * sum_j camp[p * 3 * K_MAX + c * K_MAX + j] pi_j N_j (camp: the channel's
// amplitude over pi_j; 0 for a problem without channels, whose rgb_weight is 0),
// s_c = rgb_weight * d_c / rho_c, and the objective gains rgb_weight * rho_c. The sums of dt .. dp^2 then weigh each component's density by
// s + sum_c camp_jc s_c (the components are shared by the channels), the first sum stays
// s's, and three more, s_c * pi_j N_j, follow at (6 + c) * K_MAX + j.
#ifndef L1_CH
#define L1_CH 0
#endif
#define L1_NQ (6 + L1_CH)
#define L1_NSTAT (L1_NQ * K_MAX + 1)
#define L1_ST (L1_NQ + 1)

__kernel __attribute__((reqd_work_group_size(WG, 1, 1)))
void em_l1(const uint slice_stride, const uint n_phi, const float inv_nphi,
           const float theta0, const float dtheta, const float phi0, const float dphi,
           __global const float* restrict weights, __global const int* restrict prob_slice,
           __global const int* restrict prob_k, __global const float* restrict cparams,
           __global const int* restrict prob_images, const uint n_cells, const float area,
           const float eps, __global const float* restrict prob_weights, __global const float* restrict channels,
           __global const float* restrict camp, __global real_t* restrict partials) {
  const uint p = get_group_id(1);
  const uint g = get_group_id(0);
  const uint G = get_num_groups(0);
  const uint lid = get_local_id(0);
  const int k = prob_k[p];
  __global const float* cp = cparams + p * NCONST;
  __global const int* images = prob_images + p * K_MAX;
  __global const float* w = weights + (uint)prob_slice[p] * slice_stride;
#if L1_CH
  __global const float* chw = channels + (uint)prob_slice[p] * 3 * slice_stride;
  __global const float* ca = camp + p * 3 * K_MAX;
#endif
  const float nphi = (float)n_phi;
  const float eps2 = eps * eps;
  const float kl = prob_weights[2 * p];
#if L1_CH
  const float rgb_weight = prob_weights[2 * p + 1];
#endif

  // Per component: the sums and the density of the nearest image at the current cell,
  // relative to the largest of them (em_estep's scheme: one exp2 per cell, exp2_neg per
  // component); farther images (wide components only) directly.
  floatv a[L1_ST * K_MAX];
  for (int q = 0; q < L1_ST * k; ++q) a[q] = (floatv)0.f;
  floatv obj = (floatv)0.f;

  const uint base = g * (WG * CPW * VEC);
  for (uint it = 0; it < CPW; ++it) {
    const uint c = base + (it * WG + lid) * VEC;
    const floatv wv = VLOADV(0, w + c);
    floatv t, ph;
    cell_coords(c, inv_nphi, nphi, theta0, dtheta, phi0, dphi, &t, &ph);
    const floatv valid = select((floatv)0.f, (floatv)1.f, (float)c + LANES < (float)n_cells);
    floatv top = (floatv)(-INFINITY);
    for (int j = 0; j < k; ++j) {
      const floatv dt = t - cp[0 * K_MAX + j];
      const floatv dp = wrap_diff(ph - cp[1 * K_MAX + j]);
      const floatv ej = fma(dt, fma((floatv)cp[2 * K_MAX + j], dt, cp[3 * K_MAX + j] * dp),
                            fma((floatv)cp[4 * K_MAX + j], dp * dp, (floatv)cp[5 * K_MAX + j]));
      a[L1_ST * j + L1_NQ] = ej;
      top = fmax(top, ej);
    }
    const floatv unit = exp2(top);
    floatv m = (floatv)0.f;
#if L1_CH
    floatv mc0 = (floatv)0.f, mc1 = (floatv)0.f, mc2 = (floatv)0.f;
#endif
    for (int j = 0; j < k; ++j) {
      const floatv r = unit * exp2_neg(a[L1_ST * j + L1_NQ] - top);
      a[L1_ST * j + L1_NQ] = r;
      m += r;
      floatv all = r;  // every image of component j, for the channels
      const int n = images[j];
      if (n > 0) {
        const floatv dt = t - cp[0 * K_MAX + j];
        const floatv d0 = wrap_diff(ph - cp[1 * K_MAX + j]);
        for (int img = -n; img <= n; ++img) {
          if (img == 0) continue;
          const floatv dp = d0 + (float)img * TWO_PI_F;
          const floatv e = exp2(fma(dt, fma((floatv)cp[2 * K_MAX + j], dt, cp[3 * K_MAX + j] * dp),
                                    fma((floatv)cp[4 * K_MAX + j], dp * dp, (floatv)cp[5 * K_MAX + j])));
          m += e;
          all += e;
        }
      }
#if L1_CH
      mc0 = fma((floatv)ca[0 * K_MAX + j], all, mc0);
      mc1 = fma((floatv)ca[1 * K_MAX + j], all, mc1);
      mc2 = fma((floatv)ca[2 * K_MAX + j], all, mc2);
#endif
    }
    const floatv am = fmax(area * m, (floatv)1e-30f);
    const floatv d = wv - area * m;
    const floatv rho = sqrt(fma(d, d, (floatv)eps2));
    const floatv kl_cell =
        select((floatv)0.f, LN2_F * wv * (log2_fast(fmax(wv, (floatv)1e-30f)) - log2_fast(am)), wv > 0.f);
    obj = fma(valid, fma((floatv)kl, kl_cell, rho), obj);
    const floatv s = valid * (d / rho + kl * wv / am);
#if L1_CH
    const floatv d0c = VLOADV(0, chw + c) - area * mc0;
    const floatv d1c = VLOADV(0, chw + slice_stride + c) - area * mc1;
    const floatv d2c = VLOADV(0, chw + 2 * slice_stride + c) - area * mc2;
    const floatv r0c = sqrt(fma(d0c, d0c, (floatv)eps2)), r1c = sqrt(fma(d1c, d1c, (floatv)eps2)),
                 r2c = sqrt(fma(d2c, d2c, (floatv)eps2));
    obj = fma(valid * rgb_weight, r0c + r1c + r2c, obj);
    const floatv s0c = valid * rgb_weight * d0c / r0c, s1c = valid * rgb_weight * d1c / r1c,
                 s2c = valid * rgb_weight * d2c / r2c;
#endif
    for (int j = 0; j < k; ++j) {
      const floatv dt = t - cp[0 * K_MAX + j];
      const floatv d0 = wrap_diff(ph - cp[1 * K_MAX + j]);
#if L1_CH
      const floatv seff = fma((floatv)ca[0 * K_MAX + j], s0c,
                              fma((floatv)ca[1 * K_MAX + j], s1c, fma((floatv)ca[2 * K_MAX + j], s2c, s)));
#else
      const floatv seff = s;
#endif
      const int n = images[j];
      for (int img = -n; img <= n; ++img) {
        const floatv dp = d0 + (float)img * TWO_PI_F;
        const floatv dens = img == 0 ? a[L1_ST * j + L1_NQ]
                                     : exp2(fma(dt, fma((floatv)cp[2 * K_MAX + j], dt, cp[3 * K_MAX + j] * dp),
                                                fma((floatv)cp[4 * K_MAX + j], dp * dp, (floatv)cp[5 * K_MAX + j])));
        const floatv sn = seff * dens;
        const floatv snt = sn * dt, snp = sn * dp;
#if L1_CH
        a[L1_ST * j + 0] += s * dens;
#else
        a[L1_ST * j + 0] += sn;
#endif
        a[L1_ST * j + 1] += snt;
        a[L1_ST * j + 2] += snp;
        a[L1_ST * j + 3] = fma(snt, dt, a[L1_ST * j + 3]);
        a[L1_ST * j + 4] = fma(snt, dp, a[L1_ST * j + 4]);
        a[L1_ST * j + 5] = fma(snp, dp, a[L1_ST * j + 5]);
#if L1_CH
        a[L1_ST * j + 6] = fma(s0c, dens, a[L1_ST * j + 6]);
        a[L1_ST * j + 7] = fma(s1c, dens, a[L1_ST * j + 7]);
        a[L1_ST * j + 8] = fma(s2c, dens, a[L1_ST * j + 8]);
#endif
      }
    }
  }

  __local real_t scratch[WG];
  write_sums(a, obj, k, L1_NQ, partials + (p * G + g) * L1_NSTAT, scratch);
}

// ---- Channel amplitudes of fixed Gaussians (host/fit/amplitudes.*, docs/fitting.md,
// "Colour and energy"): one evaluation of the reweighted least squares is amp_basis, then
// amp_sums, over every problem of a batch. A problem is one slice's Gaussians with the
// amplitudes of up to CH_MAX channels; its channels (integrand weights of any sign) are
// `channels + prob_slice[p] * CH_MAX * slice_stride`, channel c at c * slice_stride, zero
// on the padding.

#define CH_MAX 4
#define AMP_ROW (K_MAX + 1)
#if VEC == 1
#define VSTOREV(v, p) (*(p) = (v))
#else
#define VSTOREV(v, p) CAT(vstore, VEC)(v, 0, p)
#endif

// Per cell: the basis phi_j = area * N_j (cparams as em_l1's, with c0 = log2(area / (2 pi
// sqrt(det))): no weight), every image of prob_images, at the cell center or, where
// prob_sub[p K_MAX + j] is 1 (narrower than half a cell), the mean over 3 x 3 points of the
// cell (offsets -1/3, 0, 1/3 of a step), to basis[(p K_MAX + j) stride + cell];
// per channel c < n_channels, the residual r = w_c - sum_j amps[(p CH_MAX + c) K_MAX + j] phi_j
// and its weight d = 1 / max(|r|, delta_c) (1 where delta_c <= 0), 0 on the padding, to
// dw[(p CH_MAX + c) stride + cell]; per chunk, sum |r| to partials[(p G + g) CH_MAX + c].
// Global size (G * WG, P), local (WG, 1).
__kernel __attribute__((reqd_work_group_size(WG, 1, 1)))
void amp_basis(const uint slice_stride, const uint n_phi, const float inv_nphi,
               const float theta0, const float dtheta, const float phi0, const float dphi,
               __global const float* restrict channels, __global const int* restrict prob_slice,
               __global const int* restrict prob_k, __global const float* restrict cparams,
               __global const int* restrict prob_images, __global const int* restrict prob_sub,
               const uint n_cells, const int n_channels,
               __global const float* restrict amps, __global const float* restrict deltas,
               __global float* restrict basis, __global float* restrict dw, __global real_t* restrict partials) {
  const uint p = get_group_id(1);
  const uint g = get_group_id(0);
  const uint G = get_num_groups(0);
  const uint lid = get_local_id(0);
  const int k = prob_k[p];
  __global const float* cp = cparams + p * NCONST;
  __global const int* images = prob_images + p * K_MAX;
  __global const int* sub = prob_sub + p * K_MAX;
  __global const float* w = channels + (uint)prob_slice[p] * (CH_MAX * slice_stride);
  __global const float* amp = amps + p * (CH_MAX * K_MAX);
  __global float* bp = basis + p * (K_MAX * slice_stride);
  __global float* dp_out = dw + p * (CH_MAX * slice_stride);
  const float nphi = (float)n_phi;
  floatv l1[CH_MAX];
  for (int c = 0; c < CH_MAX; ++c) l1[c] = (floatv)0.f;

  const uint base = g * (WG * CPW * VEC);
  for (uint it = 0; it < CPW; ++it) {
    const uint c0 = base + (it * WG + lid) * VEC;
    floatv t, ph;
    cell_coords(c0, inv_nphi, nphi, theta0, dtheta, phi0, dphi, &t, &ph);
    const floatv valid = select((floatv)0.f, (floatv)1.f, (float)c0 + LANES < (float)n_cells);
    floatv r[CH_MAX];
    for (int c = 0; c < n_channels; ++c) r[c] = VLOADV(0, w + c * slice_stride + c0);
    for (int j = 0; j < k; ++j) {
      const int n = images[j], s = sub[j];
      floatv v = (floatv)0.f;
      for (int sa = -s; sa <= s; ++sa)
        for (int sb = -s; sb <= s; ++sb) {
          const floatv dt = t + (float)sa * (dtheta / 3.f) - cp[0 * K_MAX + j];
          const floatv d0 = wrap_diff(ph + (float)sb * (dphi / 3.f) - cp[1 * K_MAX + j]);
          for (int img = -n; img <= n; ++img) {
            const floatv dp = d0 + (float)img * TWO_PI_F;
            v += exp2(fma(dt, fma((floatv)cp[2 * K_MAX + j], dt, cp[3 * K_MAX + j] * dp),
                          fma((floatv)cp[4 * K_MAX + j], dp * dp, (floatv)cp[5 * K_MAX + j])));
          }
        }
      if (s) v *= 1.f / 9.f;
      VSTOREV(v, bp + j * slice_stride + c0);
      for (int c = 0; c < n_channels; ++c) r[c] = fma((floatv)(-amp[c * K_MAX + j]), v, r[c]);
    }
    for (int c = 0; c < n_channels; ++c) {
      const floatv ar = fabs(r[c]);
      const float delta = deltas[p * CH_MAX + c];
      const floatv d = delta > 0.f ? (floatv)1.f / fmax(ar, (floatv)delta) : (floatv)1.f;
      VSTOREV(valid * d, dp_out + c * slice_stride + c0);
      l1[c] = fma(valid, ar, l1[c]);
    }
  }
  __global real_t* out = partials + (p * G + g) * CH_MAX;
#if WG == 1
  for (int c = 0; c < n_channels; ++c) out[c] = hsum(l1[c]);
#else
  __local real_t scratch[WG];
  for (int c = 0; c < n_channels; ++c) {
    scratch[lid] = hsum(l1[c]);
    barrier(CLK_LOCAL_MEM_FENCE);
    for (uint span = WG / 2; span > 0; span >>= 1) {
      if (lid < span) scratch[lid] += scratch[lid + span];
      barrier(CLK_LOCAL_MEM_FENCE);
    }
    if (lid == 0) out[c] = scratch[0];
    barrier(CLK_LOCAL_MEM_FENCE);
  }
#endif
}

// The weighted normal equations, row j = get_group_id(2) of problem p: per channel c,
// sum d_c phi_j phi_i for i <= j and sum d_c w_c phi_j, over every cell of the problem,
// chunk by chunk (float lanes within a chunk of WG * CPW * VEC cells, real_t across chunks),
// to partials[((p K_MAX + j) CH_MAX + c) AMP_ROW + i], i = K_MAX the right-hand side.
// Global size (WG, P, K_MAX), local (WG, 1, 1); rows j >= K do nothing.
__kernel __attribute__((reqd_work_group_size(WG, 1, 1)))
void amp_sums(const uint slice_stride, const uint n_chunks, __global const float* restrict channels,
              __global const int* restrict prob_slice, __global const int* restrict prob_k, const int n_channels,
              __global const float* restrict basis, __global const float* restrict dw,
              __global real_t* restrict partials) {
  const uint p = get_group_id(1);
  const int j = (int)get_group_id(2);
  const uint lid = get_local_id(0);
  if (j >= prob_k[p]) return;  // the whole work-group alike
  __global const float* w = channels + (uint)prob_slice[p] * (CH_MAX * slice_stride);
  __global const float* bp = basis + p * (K_MAX * slice_stride);
  __global const float* d = dw + p * (CH_MAX * slice_stride);
  __global const float* bj = bp + (uint)j * slice_stride;
  floatv acc[CH_MAX * AMP_ROW];
  real_t tot[CH_MAX * AMP_ROW];
  for (int c = 0; c < n_channels; ++c) {
    for (int i = 0; i <= j; ++i) tot[c * AMP_ROW + i] = R(0.0);
    tot[c * AMP_ROW + K_MAX] = R(0.0);
  }
  for (uint g = 0; g < n_chunks; ++g) {
    for (int c = 0; c < n_channels; ++c) {
      for (int i = 0; i <= j; ++i) acc[c * AMP_ROW + i] = (floatv)0.f;
      acc[c * AMP_ROW + K_MAX] = (floatv)0.f;
    }
    const uint base = g * (WG * CPW * VEC);
    for (uint it = 0; it < CPW; ++it) {
      const uint c0 = base + (it * WG + lid) * VEC;
      const floatv pj = VLOADV(0, bj + c0);
      floatv u[CH_MAX];
      for (int c = 0; c < n_channels; ++c) {
        u[c] = VLOADV(0, d + c * slice_stride + c0) * pj;
        acc[c * AMP_ROW + K_MAX] = fma(u[c], VLOADV(0, w + c * slice_stride + c0), acc[c * AMP_ROW + K_MAX]);
      }
      for (int i = 0; i <= j; ++i) {
        const floatv pi = VLOADV(0, bp + (uint)i * slice_stride + c0);
        for (int c = 0; c < n_channels; ++c) acc[c * AMP_ROW + i] = fma(u[c], pi, acc[c * AMP_ROW + i]);
      }
    }
    for (int c = 0; c < n_channels; ++c) {
      for (int i = 0; i <= j; ++i) tot[c * AMP_ROW + i] += hsum(acc[c * AMP_ROW + i]);
      tot[c * AMP_ROW + K_MAX] += hsum(acc[c * AMP_ROW + K_MAX]);
    }
  }
  __global real_t* out = partials + ((p * K_MAX + (uint)j) * CH_MAX) * AMP_ROW;
#if WG == 1
  for (int c = 0; c < n_channels; ++c) {
    for (int i = 0; i <= j; ++i) out[c * AMP_ROW + i] = tot[c * AMP_ROW + i];
    out[c * AMP_ROW + K_MAX] = tot[c * AMP_ROW + K_MAX];
  }
#else
  __local real_t scratch[WG];
  for (int c = 0; c < n_channels; ++c)
    for (int i = 0; i <= j + 1; ++i) {
      const int q = c * AMP_ROW + (i <= j ? i : K_MAX);
      scratch[lid] = tot[q];
      barrier(CLK_LOCAL_MEM_FENCE);
      for (uint span = WG / 2; span > 0; span >>= 1) {
        if (lid < span) scratch[lid] += scratch[lid + span];
        barrier(CLK_LOCAL_MEM_FENCE);
      }
      if (lid == 0) out[q] = scratch[0];
      barrier(CLK_LOCAL_MEM_FENCE);
    }
#endif
}
