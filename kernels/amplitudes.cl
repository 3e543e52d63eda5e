// The amplitude fit's sums (host/fit/amplitude_engine.cpp).
// Built after kernels/common.cl and kernels/fit_common.cl.

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
  const uint p = get_group_id(1), g = get_group_id(0), G = get_num_groups(0), lid = get_local_id(0);
  const int k = prob_k[p];
  __global const float* cp = cparams + p * NCONST;
  __global const int* images = prob_images + p * K_MAX;
  __global const int* sub = prob_sub + p * K_MAX;
  __global const float* w = channels + (uint)prob_slice[p] * (CH_MAX * slice_stride);
  __global const float* amp = amps + p * (CH_MAX * K_MAX);
  __global float* bp = basis + p * (K_MAX * slice_stride);
  __global float* dp_out = dw + p * (CH_MAX * slice_stride);
  const slice_grid grid = make_grid(n_phi, inv_nphi, theta0, dtheta, phi0, dphi);
  floatv l1[CH_MAX];
  for (int c = 0; c < CH_MAX; ++c) l1[c] = (floatv)0.f;

  for (uint it = 0; it < CPW; ++it) {
    floatv t, ph;
    const uint c0 = grid_cell_angles(&grid, g, it, lid, &t, &ph);
    floatv x, y;
    map_point(t, ph, &x, &y);
    const floatv jac = plane_jacobian(x, y);
    const floatv valid = select((floatv)0.f, (floatv)1.f, (float)c0 + LANES < (float)n_cells);
    floatv r[CH_MAX];
    for (int c = 0; c < n_channels; ++c) r[c] = VLOADV(0, w + c * slice_stride + c0);
    for (int j = 0; j < k; ++j) {
      const int n = images[j], s = sub[j];
      floatv v = (floatv)0.f;
      for (int sa = -s; sa <= s; ++sa)
        for (int sb = -s; sb <= s; ++sb) {
          floatv px = x, py = y;
          if (s) map_point(t + (float)sa * (dtheta / 3.f), ph + (float)sb * (dphi / 3.f), &px, &py);
          const floatv dt = px - cp[0 * K_MAX + j];
          const floatv d0 = wrap_diff(py - cp[1 * K_MAX + j]);
          for (int img = -n; img <= n; ++img) v += exp2(component_log2(cp, j, dt, image_offset(d0, img)));
        }
      v *= s ? jac * (1.f / 9.f) : jac;
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
    const real_t total = group_sum(hsum(l1[c]), scratch);
    if (lid == 0) out[c] = total;
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
    for (uint it = 0; it < CPW; ++it) {
      const uint c0 = chunk_cell(g, it, lid);
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
      const real_t total = group_sum(tot[q], scratch);
      if (lid == 0) out[q] = total;
    }
#endif
}
