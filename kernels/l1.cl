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
#define L1_ST (L1_NQ + 1)

// The density of every component at cells (t, ph) (cparams `cp`, images of prob_images):
// the nearest image's, relative to the largest of them times 2^largest, to
// a[L1_ST j + L1_NQ] (em_estep's scheme: one exp2 per cell, exp2_neg per component),
// farther images (wide components only) directly. Returns the mixture's density summed
// over every image; with L1_CH, mc[c] the channels' (amplitudes `ca`).
inline floatv l1_densities(__global const float* cp, __global const int* images, __global const float* ca,
                           const int k, const floatv t, const floatv ph, floatv* a, floatv* mc) {
  floatv top = (floatv)(-INFINITY);
  for (int j = 0; j < k; ++j) {
    floatv dt, dp;
    component_offsets(cp, j, t, ph, &dt, &dp);
    const floatv ej = component_log2(cp, j, dt, dp);
    a[L1_ST * j + L1_NQ] = ej;
    top = fmax(top, ej);
  }
  const floatv unit = exp2(top);
  floatv m = (floatv)0.f;
#if L1_CH
  mc[0] = mc[1] = mc[2] = (floatv)0.f;
#endif
  for (int j = 0; j < k; ++j) {
    const floatv r = unit * exp2_neg(a[L1_ST * j + L1_NQ] - top);
    a[L1_ST * j + L1_NQ] = r;
    m += r;
    floatv all = r;  // every image of component j, for the channels
    const int n = images[j];
    if (n > 0) {
      floatv dt, d0;
      component_offsets(cp, j, t, ph, &dt, &d0);
      for (int img = -n; img <= n; ++img) {
        if (img == 0) continue;
        const floatv e = exp2(component_log2(cp, j, dt, image_offset(d0, img)));
        m += e;
        all += e;
      }
    }
#if L1_CH
    for (int c = 0; c < 3; ++c) mc[c] = fma((floatv)ca[c * K_MAX + j], all, mc[c]);
#endif
  }
  return m;
}

// Adds the gradient statistics of cells (t, ph) to a: per component and image, the density
// (a[L1_ST j + L1_NQ] for the nearest image, as l1_densities left it) times s (with L1_CH
// plus the channels' sc[c] by their amplitudes `ca`) times (1, dt, dp, dt^2, dt dp, dp^2);
// with L1_CH the first sum is s's alone and sc[c] times the density follow.
inline void l1_accumulate(__global const float* cp, __global const int* images, __global const float* ca,
                          const int k, const floatv t, const floatv ph, const floatv s, const floatv* sc, floatv* a) {
  for (int j = 0; j < k; ++j) {
    floatv dt, d0;
    component_offsets(cp, j, t, ph, &dt, &d0);
#if L1_CH
    const floatv seff = fma((floatv)ca[0 * K_MAX + j], sc[0],
                            fma((floatv)ca[1 * K_MAX + j], sc[1], fma((floatv)ca[2 * K_MAX + j], sc[2], s)));
#else
    const floatv seff = s;
#endif
    const int n = images[j];
    for (int img = -n; img <= n; ++img) {
      const floatv dp = image_offset(d0, img);
      const floatv dens = img == 0 ? a[L1_ST * j + L1_NQ] : exp2(component_log2(cp, j, dt, dp));
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
      for (int c = 0; c < 3; ++c) a[L1_ST * j + 6 + c] = fma(sc[c], dens, a[L1_ST * j + 6 + c]);
#endif
    }
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

  // Per component: the sums, then the density of the nearest image at the current cell.
  floatv a[L1_ST * K_MAX];
  for (int q = 0; q < L1_ST * k; ++q) a[q] = (floatv)0.f;
  floatv obj = (floatv)0.f;
  floatv mc[3], sc[3];

  for (uint it = 0; it < CPW; ++it) {
    floatv t, ph;
    const uint c = grid_cell(&grid, g, it, lid, &t, &ph);
    const floatv wv = VLOADV(0, w + c);
    const floatv valid = select((floatv)0.f, (floatv)1.f, (float)c + LANES < (float)n_cells);
    const floatv jac = plane_jacobian(t, ph);  // the cell's area over `area` (1 on (theta, phi))
    const floatv cell = area * jac;
    const floatv m = l1_densities(cp, images, ca, k, t, ph, a, mc);
    const floatv am = fmax(cell * m, (floatv)1e-30f);
    const floatv d = wv - cell * m;
    const floatv rho = sqrt(fma(d, d, (floatv)eps2));
    const floatv kl_cell =
        select((floatv)0.f, LN2_F * wv * (log2_fast(fmax(wv, (floatv)1e-30f)) - log2_fast(am)), wv > 0.f);
    obj = fma(valid, fma((floatv)kl, kl_cell, rho), obj);
    const floatv s = valid * jac * (d / rho + kl * wv / am);
#if L1_CH
    floatv rc[3];
    for (int ch = 0; ch < 3; ++ch) {
      const floatv dc = VLOADV(0, chw + ch * slice_stride + c) - cell * mc[ch];
      rc[ch] = sqrt(fma(dc, dc, (floatv)eps2));
      sc[ch] = valid * jac * rgb_weight * dc / rc[ch];
    }
    obj = fma(valid * rgb_weight, rc[0] + rc[1] + rc[2], obj);
#endif
    l1_accumulate(cp, images, ca, k, t, ph, s, sc, a);
  }

  __local real_t scratch[WG];
  write_sums(a, obj, k, L1_NQ, partials + (p * G + g) * L1_NSTAT, scratch);
}
