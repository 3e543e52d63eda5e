// Weighted EM for 2D Gaussian mixtures over (theta, phi) cell grids, phi periodic.
// See docs/em.md for the equations; host/fit/em_reference.cpp is the CPU reference.
//
// Built after kernels/common.cl and kernels/fit_common.cl (the cell layout, the defines
// K_MAX, VEC, WG, CPW, EM_FP64 and the fast math).

// Status per problem: [2p] = 0 running, 1 done, 2 failed; [2p + 1] = iterations (M-steps) done.

// The arguments of em_estep and em_loglik: the grid (host/fit/em_engine.cpp set_grid_args),
// the slices' weights, the problems' slices, K, status and E-step constants, and the
// partial sums per chunk.
#define EM_CELL_PARAMS                                                                                      \
  const uint slice_stride, const uint n_phi, const float inv_nphi, const float theta0, const float dtheta, \
      const float phi0, const float dphi, __global const float* restrict weights,                         \
      __global const int* restrict prob_slice, __global const int* restrict prob_k,                        \
      __global const int* restrict status, __global const float* restrict cparams,                         \
      __global real_t* restrict partials

// Cell vectors per step of em_estep: 8 where the vectors are wide (the statistics' loads
// and stores then serve 8 vectors, and the vectors' chains of max and sum overlap; 2 past
// K_MAX 64, which would take too much private memory), else 1. EM_KEEP 1: the first pass
// keeps each component's offsets (dt, dp) for the statistics pass; 0: that pass recomputes
// them. Measured on PoCL (AVX-512): docs/studies/em_kernels.md, "Steps of several cell vectors".
#ifndef EM_NV
#if VEC > 1 && CPW % 8 == 0 && K_MAX <= 64
#define EM_NV 8
#elif VEC > 1 && CPW % 2 == 0
#define EM_NV 2
#else
#define EM_NV 1
#endif
#endif
#ifndef EM_KEEP
#define EM_KEEP (VEC > 1)
#endif
// Per component j, at a[EM_NA j + ..]: the six sums, then per cell vector v the E-step
// value and (EM_KEEP) the offsets dt, dp. Interleaved: separate arrays of K_MAX vectors
// would sit 4 KiB apart and alias in the L1 cache.
#define EM_NE (1 + 2 * EM_KEEP)
#define EM_NA (6 + EM_NE * EM_NV)

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
void em_estep(EM_CELL_PARAMS) {
  const uint p = get_group_id(1), g = get_group_id(0), G = get_num_groups(0), lid = get_local_id(0);
  if (status[2 * p] != 0) return;
  const int k = prob_k[p];
  __global const float* cp = cparams + p * NCONST;
  __global const float* w = weights + (uint)prob_slice[p] * slice_stride;
  const slice_grid grid = make_grid(n_phi, inv_nphi, theta0, dtheta, phi0, dphi);

  floatv a[EM_NA * K_MAX];
#define EV(j, v, q) a[EM_NA * (j) + 6 + EM_NE * (v) + (q)]
  for (int j = 0; j < k; ++j)
    for (int q = 0; q < 6; ++q) a[EM_NA * j + q] = (floatv)0.f;
  floatv ll = (floatv)0.f;

  for (uint it = 0; it < CPW; it += EM_NV) {
    floatv t[EM_NV], ph[EM_NV], wv[EM_NV], m[EM_NV], s[EM_NV];
    #pragma unroll
    for (int v = 0; v < EM_NV; ++v) {
      const uint c = grid_cell(&grid, g, it + v, lid, &t[v], &ph[v]);
      wv[v] = VLOADV(0, w + c);
      m[v] = (floatv)(-INFINITY);
      s[v] = (floatv)0.f;
    }
    for (int j = 0; j < k; ++j)
      #pragma unroll
      for (int v = 0; v < EM_NV; ++v) {
        floatv dt, dp;
        component_offsets(cp, j, t[v], ph[v], &dt, &dp);
        const floatv ej = component_log2(cp, j, dt, dp);
        EV(j, v, 0) = ej;
#if EM_KEEP
        EV(j, v, 1) = dt;
        EV(j, v, 2) = dp;
#endif
        m[v] = select(m[v], ej, ej > m[v]);
      }
    for (int j = 0; j < k; ++j)
      #pragma unroll
      for (int v = 0; v < EM_NV; ++v) {
        const floatv r = exp2_neg(EV(j, v, 0) - m[v]);
        EV(j, v, 0) = r;
        s[v] += r;
      }
    floatv f[EM_NV];
    #pragma unroll
    for (int v = 0; v < EM_NV; ++v) {
      f[v] = wv[v] / s[v];
      ll = fma(wv[v], m[v] + log2_fast(s[v]), ll);
    }
    for (int j = 0; j < k; ++j) {
      floatv s0 = a[EM_NA * j], s1 = a[EM_NA * j + 1], s2 = a[EM_NA * j + 2];
      floatv s3 = a[EM_NA * j + 3], s4 = a[EM_NA * j + 4], s5 = a[EM_NA * j + 5];
      #pragma unroll
      for (int v = 0; v < EM_NV; ++v) {
        floatv dt, dp;
#if EM_KEEP
        dt = EV(j, v, 1);
        dp = EV(j, v, 2);
#else
        component_offsets(cp, j, t[v], ph[v], &dt, &dp);
#endif
        const floatv rw = f[v] * EV(j, v, 0);
        const floatv rwt = rw * dt, rwp = rw * dp;
        s0 += rw;
        s1 += rwt;
        s2 += rwp;
        s3 = fma(rwt, dt, s3);
        s4 = fma(rwt, dp, s4);
        s5 = fma(rwp, dp, s5);
      }
      a[EM_NA * j] = s0;
      a[EM_NA * j + 1] = s1;
      a[EM_NA * j + 2] = s2;
      a[EM_NA * j + 3] = s3;
      a[EM_NA * j + 4] = s4;
      a[EM_NA * j + 5] = s5;
    }
  }
#undef EV

  __local real_t scratch[WG];
  write_sums(a, EM_NA, ll, k, 6, partials + (p * G + g) * NSTAT, scratch);
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

// Marks problem p failed after iteration iter - 1.
inline void fail_problem(__global int* status, uint p, int iter) {
  status[2 * p] = 2;
  status[2 * p + 1] = iter - 1;
}

// The M-step of component j from problem p's chunk statistics (`total`: the responsibility
// mass of every component): weight, mean (phi wrapped) and covariance (floored). False,
// the state untouched, when the component is empty (mass at most min_weight * total).
inline bool update_component(__global real_t* st, __global const real_t* partials, uint p, uint G, int j,
                             const real_t total, const real_t cov_floor, const real_t min_weight) {
  const real_t s0 = sum_chunks(partials, p, G, 0 * K_MAX + j);
  if (!(s0 > min_weight * total)) return false;
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
  return true;
}

// Re-seeds the empty component j by splitting component h along its principal axis:
// means +- half a standard deviation, weight halved, covariance kept.
inline void split_component(__global real_t* st, int j, int h) {
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
    fail_problem(status, p, iter);
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
    fail_problem(status, p, iter);
    return;
  }
  bool empty[K_MAX];
  for (int j = 0; j < k; ++j) empty[j] = !update_component(st, partials, p, G, j, total, cov_floor, min_weight);
  // Each empty component (in index order) splits the heaviest non-empty one.
  for (int j = 0; j < k; ++j) {
    if (!empty[j]) continue;
    int h = -1;
    for (int i = 0; i < k; ++i)
      if (!empty[i] && (h < 0 || st[0 * K_MAX + i] > st[0 * K_MAX + h])) h = i;
    if (h < 0) {
      fail_problem(status, p, iter);
      return;
    }
    split_component(st, j, h);
    empty[j] = false;
  }
  real_t wsum = R(0.0);
  for (int j = 0; j < k; ++j) wsum += st[0 * K_MAX + j];
  for (int j = 0; j < k; ++j) st[0 * K_MAX + j] /= wsum;
  for (int j = 0; j < k; ++j) component_constants(st, cparams + p * NCONST, j);
  status[2 * p + 1] = iter;
  if (iter >= max_iter) status[2 * p] = 1;
}

// log2 of the mixture's exact periodic density at cells (t, ph): every component summed
// over the phi images m = -1, 0, 1, relative to the largest term.
inline floatv periodic_log2(__global const float* cp, const int k, const floatv t, const floatv ph) {
  floatv m = (floatv)(-INFINITY);
  for (int j = 0; j < k; ++j) {
    floatv dt, d0;
    component_offsets(cp, j, t, ph, &dt, &d0);
    for (int img = -1; img <= 1; ++img) m = fmax(m, component_log2(cp, j, dt, image_offset(d0, img)));
  }
  floatv s = (floatv)0.f;
  for (int j = 0; j < k; ++j) {
    floatv dt, d0;
    component_offsets(cp, j, t, ph, &dt, &d0);
    for (int img = -1; img <= 1; ++img) s += exp2(component_log2(cp, j, dt, image_offset(d0, img)) - m);
  }
  return m + log2(s);
}

// The weighted log-likelihood (natural log) of the final state with the exact
// periodic density: every component summed over the phi images m = -1, 0, 1.
// One partial per chunk; the host adds them. Same grid as em_estep.
__kernel __attribute__((reqd_work_group_size(WG, 1, 1)))
void em_loglik(EM_CELL_PARAMS) {
  const uint p = get_group_id(1), g = get_group_id(0), G = get_num_groups(0), lid = get_local_id(0);
  if (status[2 * p] == 2) return;
  const int k = prob_k[p];
  __global const float* cp = cparams + p * NCONST;
  __global const float* w = weights + (uint)prob_slice[p] * slice_stride;
  const slice_grid grid = make_grid(n_phi, inv_nphi, theta0, dtheta, phi0, dphi);
  floatv ll = (floatv)0.f;
  for (uint it = 0; it < CPW; ++it) {
    floatv t, ph;
    const uint c = grid_cell(&grid, g, it, lid, &t, &ph);
    ll += VLOADV(0, w + c) * periodic_log2(cp, k, t, ph);
  }
#if WG == 1
  partials[p * G + g] = LN2_R * hsum(ll);
#else
  __local real_t scratch[WG];
  const real_t total = group_sum(hsum(ll), scratch);
  if (lid == 0) partials[p * G + g] = LN2_R * total;
#endif
}
