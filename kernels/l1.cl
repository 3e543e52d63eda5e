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
