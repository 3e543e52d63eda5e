// The L1 refinement's objective and gradient statistics (host/fit/l1_engine.cpp).
// Built after kernels/common.cl and kernels/fit_common.cl.

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
// Cell vectors per step: 4 where the vectors are wide (the sums' loads and stores serve
// 4 vectors; 1 past K_MAX 64, which would take too much private memory), else 1.
#ifndef L1_NV
#if VEC > 1 && CPW % 4 == 0 && K_MAX <= 64
#define L1_NV 4
#else
#define L1_NV 1
#endif
#endif
// Per component j, at a[L1_ST j + ..]: the L1_NQ sums, then per cell vector v the density
// of the nearest image and the offsets dt, dp at L1_NQ + 3 v + (0, 1, 2).
#define L1_ST (L1_NQ + 3 * L1_NV)

// 2^x, 0 below 2^-125 (kernels/common.cl bsdfmix_exp2: no library call, 2.2e-7 relative).
inline floatv l1_exp2(const floatv x) {
#if VEC == 1
  return x >= -125.0f ? bsdfmix_exp2(x) : 0.0f;
#else
  return select((floatv)0.0f, CAT(bsdfmix_exp2, VEC)(x), x >= -125.0f);
#endif
}

// The density of every component at cells (t, ph) (cparams `cp`, images of prob_images):
// the nearest image's, relative to the largest of them times 2^largest, to e[L1_ST j]
// with its offsets dt, dp at e[L1_ST j + 1], e[L1_ST j + 2] (em_estep's scheme: one exp2
// per cell, exp2_neg per component), farther images (wide components only) directly.
// Returns the mixture's density summed over every image; with L1_CH, mc[c] the channels'
// (amplitudes `ca`).
inline __attribute__((always_inline)) floatv l1_densities(__global const float* cp, __global const int* images,
                                                          __global const float* ca, const int k, const floatv t,
                                                          const floatv ph, floatv* e, floatv* mc) {
  floatv top = (floatv)(-INFINITY);
  for (int j = 0; j < k; ++j) {
    floatv dt, dp;
    component_offsets(cp, j, t, ph, &dt, &dp);
    const floatv ej = component_log2(cp, j, dt, dp);
    e[L1_ST * j] = ej;
    e[L1_ST * j + 1] = dt;
    e[L1_ST * j + 2] = dp;
    top = fmax(top, ej);
  }
  const floatv unit = l1_exp2(top);
  floatv m = (floatv)0.f;
#if L1_CH
  mc[0] = mc[1] = mc[2] = (floatv)0.f;
#endif
  for (int j = 0; j < k; ++j) {
    const floatv r = unit * exp2_neg(e[L1_ST * j] - top);
    e[L1_ST * j] = r;
    m += r;
    floatv all = r;  // every image of component j, for the channels
    const int n = images[j];
    if (n > 0) {
      const floatv dt = e[L1_ST * j + 1], d0 = e[L1_ST * j + 2];
      for (int img = -n; img <= n; ++img) {
        if (img == 0) continue;
        const floatv x = l1_exp2(component_log2(cp, j, dt, image_offset(d0, img)));
        m += x;
        all += x;
      }
    }
#if L1_CH
    for (int c = 0; c < 3; ++c) mc[c] = fma((floatv)ca[c * K_MAX + j], all, mc[c]);
#endif
  }
  return m;
}

// Adds one image's terms to the sums q of one component: its density times seff times
// (1, dt, dp, dt^2, dt dp, dp^2), the first with s instead of seff where L1_CH, and the
// channels' sc[c] times the density after them.
inline __attribute__((always_inline)) void l1_add(floatv* q, const floatv s, const floatv seff, const floatv* sc,
                                                  const floatv dens, const floatv dt, const floatv dp) {
  const floatv sn = seff * dens;
  const floatv snt = sn * dt, snp = sn * dp;
#if L1_CH
  q[0] += s * dens;
#else
  q[0] += sn;
#endif
  q[1] += snt;
  q[2] += snp;
  q[3] = fma(snt, dt, q[3]);
  q[4] = fma(snt, dp, q[4]);
  q[5] = fma(snp, dp, q[5]);
#if L1_CH
  for (int c = 0; c < 3; ++c) q[6 + c] = fma(sc[c], dens, q[6 + c]);
#endif
}

// Adds the gradient statistics of L1_NV cell vectors to a: per component and image, the
// density (for the nearest image, as l1_densities left it) times s[v] (with L1_CH plus the
// channels' sc[3 v + c] by their amplitudes `ca`) times (1, dt, dp, dt^2, dt dp, dp^2); with
// L1_CH the first sum is s's alone and sc[3 v + c] times the density follow.
inline __attribute__((always_inline)) void l1_accumulate(__global const float* cp, __global const int* images,
                                                         __global const float* ca, const int k, const floatv* s,
                                                         const floatv* sc, floatv* a) {
  for (int j = 0; j < k; ++j) {
    floatv q[L1_NQ];
#pragma unroll
    for (int i = 0; i < L1_NQ; ++i) q[i] = a[L1_ST * j + i];
    const int n = images[j];
#pragma unroll
    for (int v = 0; v < L1_NV; ++v) {
      const floatv* e = a + L1_ST * j + L1_NQ + 3 * v;
      const floatv dt = e[1], d0 = e[2];
#if L1_CH
      const floatv s2 = fma((floatv)ca[2 * K_MAX + j], sc[3 * v + 2], s[v]);
      const floatv seff = fma((floatv)ca[0 * K_MAX + j], sc[3 * v], fma((floatv)ca[1 * K_MAX + j], sc[3 * v + 1], s2));
#else
      const floatv seff = s[v];
#endif
      for (int img = -n; img < 0; ++img) {
        const floatv dp = image_offset(d0, img);
        l1_add(q, s[v], seff, sc + 3 * v, l1_exp2(component_log2(cp, j, dt, dp)), dt, dp);
      }
      l1_add(q, s[v], seff, sc + 3 * v, e[0], dt, d0);
      for (int img = 1; img <= n; ++img) {
        const floatv dp = image_offset(d0, img);
        l1_add(q, s[v], seff, sc + 3 * v, l1_exp2(component_log2(cp, j, dt, dp)), dt, dp);
      }
    }
#pragma unroll
    for (int i = 0; i < L1_NQ; ++i) a[L1_ST * j + i] = q[i];
  }
}

__kernel __attribute__((reqd_work_group_size(WG, 1, 1)))
void em_l1(const uint slice_stride, const uint n_phi, const float inv_nphi,
           const float theta0, const float dtheta, const float phi0, const float dphi,
           __global const float* restrict weights, __global const int* restrict prob_slice,
           __global const int* restrict prob_k, __global const float* restrict cparams,
           __global const int* restrict prob_images, const uint n_cells, const float area,
           const float eps, __global const float* restrict prob_weights, __global const float* restrict channels,
           __global const float* restrict camp, __global real_t* restrict partials) {
  const uint p = get_group_id(1), g = get_group_id(0), G = get_num_groups(0), lid = get_local_id(0);
  const int k = prob_k[p];
  __global const float* cp = cparams + p * NCONST;
  __global const int* images = prob_images + p * K_MAX;
  __global const float* w = weights + (uint)prob_slice[p] * slice_stride;
  __global const float* ca = camp + p * 3 * K_MAX;
#if L1_CH
  __global const float* chw = channels + (uint)prob_slice[p] * 3 * slice_stride;
  const float rgb_weight = prob_weights[2 * p + 1];
#endif
  const slice_grid grid = make_grid(n_phi, inv_nphi, theta0, dtheta, phi0, dphi);
  const float eps2 = eps * eps;
  const float kl = prob_weights[2 * p];

  floatv a[L1_ST * K_MAX];
  for (int j = 0; j < k; ++j)
    for (int q = 0; q < L1_NQ; ++q) a[L1_ST * j + q] = (floatv)0.f;
  floatv obj = (floatv)0.f;

  for (uint it = 0; it < CPW; it += L1_NV) {
    floatv s[L1_NV], sc[3 * L1_NV], mc[3];
#pragma unroll
    for (int v = 0; v < L1_NV; ++v) {
      floatv t, ph;
      const uint c = grid_cell(&grid, g, it + v, lid, &t, &ph);
      const floatv wv = VLOADV(0, w + c);
      const floatv valid = select((floatv)0.f, (floatv)1.f, (float)c + LANES < (float)n_cells);
      const floatv jac = plane_jacobian(t, ph);  // the cell's area over `area` (1 on (theta, phi))
      const floatv cell = area * jac;
      const floatv m = l1_densities(cp, images, ca, k, t, ph, a + L1_NQ + 3 * v, mc);
      const floatv am = fmax(cell * m, (floatv)1e-30f);
      const floatv d = wv - cell * m;
      const floatv rho = sqrt(fma(d, d, (floatv)eps2));
      const floatv kl_cell =
          select((floatv)0.f, LN2_F * wv * (log2_fast(fmax(wv, (floatv)1e-30f)) - log2_fast(am)), wv > 0.f);
      obj = fma(valid, fma((floatv)kl, kl_cell, rho), obj);
      s[v] = valid * jac * (d / rho + kl * wv / am);
#if L1_CH
      floatv rc[3];
      for (int ch = 0; ch < 3; ++ch) {
        const floatv dc = VLOADV(0, chw + ch * slice_stride + c) - cell * mc[ch];
        rc[ch] = sqrt(fma(dc, dc, (floatv)eps2));
        sc[3 * v + ch] = valid * jac * rgb_weight * dc / rc[ch];
      }
      obj = fma(valid * rgb_weight, rc[0] + rc[1] + rc[2], obj);
#endif
    }
    l1_accumulate(cp, images, ca, k, s, sc, a);
  }

  __local real_t scratch[WG];
  write_sums(a, L1_ST, obj, k, L1_NQ, partials + (p * G + g) * L1_NSTAT, scratch);
}
