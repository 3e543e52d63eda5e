// Tabulation of the Chiang et al. 2016 fiber BCSDF (docs/fiber.md), a batch of
// omega_o slices at a time, in float. CPU reference: host/tables/fiber_model.cpp;
// test: tests/fiber_test.cpp.
//
// Per channel c of linear RGB (R, G, B), f_c(theta_o, theta_i, dphi) = sum_p M_p(theta_o,
// theta_i) * Nbar_cp(theta_o, dphi), where Nbar_cp = (1/2) sum_k w_k A_cp(theta_o, h_k)
// N_p(dphi; theta_o, h_k) is the h-averaged azimuthal factor (Gauss-Legendre nodes h_k,
// weights w_k). The geometry (M_p, N_p, Fresnel, path lengths) is shared by the channels;
// only the transmittance exp(-sigma_a[c] * path) in A_cp differs. Three kernels:
//   fiber_azimuthal:    Nbar[b][c][p][j]  for each slice b of the batch and phi_i cell j
//   fiber_longitudinal: M[b][p][i]        for each theta_i cell i
//   fiber_combine:      rgb[b][i][j][c] = sum_p M[b][p][i] Nbar[b][c][p][j], times the
//                       noise factor of the cell (one factor for the three channels)
// Slice s of the table (s = t_o * n_phi_o + p_o) is batch entry b = s - first_slice. The
// table's `values` (the luminance of rgb) is computed on the host.
// philox4x32_10 and wrap_phi: kernels/common.cl.

#ifndef I0_SERIES_TERMS
#define I0_SERIES_TERMS 30  // power-series terms of I0 below I0_ASYMPTOTIC_FROM
#endif
#ifndef I0_ASYMPTOTIC_FROM
#define I0_ASYMPTOTIC_FROM 15.0f  // above: the asymptotic expansion with 5 terms
#endif
#ifndef LOBES
#define LOBES 4  // R, TT, TRT, residual
#endif
#define CHANNELS 3  // R, G, B

#define FIBER_PI 3.14159265358979323846f

// Model parameters, identical for every work item.
typedef struct {
  float eta, s, logistic_norm;  // logistic_norm = CDF(pi) - CDF(-pi)
  float sigma_a[CHANNELS];      // absorption per unit radius, R, G, B
  float v[LOBES];               // longitudinal variances
  float tilt[LOBES];            // theta_o shift of each lobe: -2a, a, 4a, 0
} FiberParams;

// log(I0(x) exp(-x)), x >= 0.
float log_i0_scaled(const float x) {
  if (x < I0_ASYMPTOTIC_FROM) {
    const float q = 0.25f * x * x;
    float term = 1.0f, sum = 1.0f;
    for (int i = 1; i <= I0_SERIES_TERMS; ++i) {
      term *= q / (float)(i * i);
      sum += term;
    }
    return log(sum) - x;
  }
  const float t = 1.0f / (8.0f * x);
  const float poly = 1.0f + t * (1.0f + t * (4.5f + t * (37.5f + t * (459.375f + t * 7441.875f))));
  return -0.5f * log(2.0f * FIBER_PI * x) + log(poly);
}

float fresnel_dielectric(float cos_i, const float eta) {
  cos_i = clamp(cos_i, 0.0f, 1.0f);
  const float sin_t = sqrt(fmax(0.0f, 1.0f - cos_i * cos_i)) / eta;
  const float cos_t = sqrt(fmax(0.0f, 1.0f - sin_t * sin_t));
  const float r_par = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
  const float r_perp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
  return 0.5f * (r_par * r_par + r_perp * r_perp);
}

float trimmed_logistic(const float x, const float s, const float norm) {
  const float e = exp(-fabs(x) / s);
  return e / (s * (1.0f + e) * (1.0f + e) * norm);
}

// M_p with the tilted theta_o' mirrored back into [-pi/2, pi/2] (same as |cos theta_o'|).
float longitudinal(const float v, const float theta_op_raw, const float theta_i) {
  float theta_op = theta_op_raw;
  if (theta_op > 0.5f * FIBER_PI) theta_op = FIBER_PI - theta_op;
  if (theta_op < -0.5f * FIBER_PI) theta_op = -FIBER_PI - theta_op;
  const float a = cos(theta_i) * cos(theta_op) / v;
  const float sh = sin(0.5f * (theta_i + theta_op));
  // a - b - 1/v = (cos(theta_i + theta_o') - 1) / v
  const float log_m = log_i0_scaled(a) - 2.0f * sh * sh / v - log(v) - log1p(-exp(-2.0f / v));
  return exp(log_m);
}

// Multiplicative log-normal noise factor of table cell `cell` (mean 1, never negative).
float noise_factor(const ulong cell, const ulong seed, const float level) {
  const uint4 r = philox4x32_10((uint4)((uint)cell, (uint)(cell >> 32), 0x66696265u, 0u),
                                (uint2)((uint)seed, (uint)(seed >> 32)));
  const float u1 = ((float)(r.x >> 8) + 0.5f) * (1.0f / 16777216.0f);
  const float u2 = ((float)(r.y >> 8) + 0.5f) * (1.0f / 16777216.0f);
  const float z = sqrt(-2.0f * log(u1)) * cos(2.0f * FIBER_PI * u2);
  return exp(level * z - 0.5f * level * level);
}

// global (n_phi_i, batch)
__kernel void fiber_azimuthal(const FiberParams prm, __global const float* theta_o, __global const float* phi_o,
                              __global const float* phi_i, __global const float2* h_rule, const uint n_h,
                              const uint n_phi_o, const uint n_phi_i, const uint first_slice, const uint batch,
                              __global float* nbar) {
  const uint j = get_global_id(0), b = get_global_id(1);
  if (j >= n_phi_i || b >= batch) return;
  const uint s_idx = first_slice + b;
  const float th_o = theta_o[s_idx / n_phi_o];
  const float dphi = phi_i[j] - phi_o[s_idx % n_phi_o];
  const float sin_o = sin(th_o), cos_o = fmax(cos(th_o), 1e-7f);
  const float sin_t = sin_o / prm.eta, cos_t = sqrt(fmax(0.0f, 1.0f - sin_t * sin_t));
  const float etap = sqrt(prm.eta * prm.eta - sin_o * sin_o) / cos_o;
  float acc[CHANNELS][LOBES];
  for (int c = 0; c < CHANNELS; ++c)
    for (int p = 0; p < LOBES; ++p) acc[c][p] = 0.0f;
  for (uint k = 0; k < n_h; ++k) {
    const float h = h_rule[k].x, w = h_rule[k].y;
    const float sin_gt = h / etap, cos_gt = sqrt(fmax(0.0f, 1.0f - sin_gt * sin_gt));
    const float gamma_o = asin(clamp(h, -1.0f, 1.0f)), gamma_t = asin(clamp(sin_gt, -1.0f, 1.0f));
    const float path = 2.0f * cos_gt / cos_t;
    const float F = fresnel_dielectric(cos_o * sqrt(fmax(0.0f, 1.0f - h * h)), prm.eta);
    const float wn0 = w * trimmed_logistic(wrap_phi(dphi + 2.0f * gamma_o), prm.s, prm.logistic_norm);
    const float wn1 = w * trimmed_logistic(wrap_phi(dphi - (2.0f * gamma_t - 2.0f * gamma_o + FIBER_PI)), prm.s,
                                           prm.logistic_norm);
    const float wn2 = w * trimmed_logistic(wrap_phi(dphi - (4.0f * gamma_t - 2.0f * gamma_o + 2.0f * FIBER_PI)),
                                           prm.s, prm.logistic_norm);
    for (int c = 0; c < CHANNELS; ++c) {
      const float T = exp(-prm.sigma_a[c] * path);
      const float a1 = (1.0f - F) * (1.0f - F) * T, a2 = a1 * T * F;
      const float a3 = a2 * F * T / fmax(1.0f - T * F, 1e-30f);
      acc[c][0] += F * wn0;
      acc[c][1] += a1 * wn1;
      acc[c][2] += a2 * wn2;
      acc[c][3] += w * a3;
    }
  }
  __global float* out = nbar + (size_t)b * CHANNELS * LOBES * n_phi_i;
  for (int c = 0; c < CHANNELS; ++c) {
    out[(c * LOBES + 0) * n_phi_i + j] = 0.5f * acc[c][0];
    out[(c * LOBES + 1) * n_phi_i + j] = 0.5f * acc[c][1];
    out[(c * LOBES + 2) * n_phi_i + j] = 0.5f * acc[c][2];
    out[(c * LOBES + 3) * n_phi_i + j] = 0.5f * acc[c][3] / (2.0f * FIBER_PI);
  }
}

// global (n_theta_i, batch)
__kernel void fiber_longitudinal(const FiberParams prm, __global const float* theta_o, __global const float* theta_i,
                                 const uint n_phi_o, const uint n_theta_i, const uint first_slice, const uint batch,
                                 __global float* m) {
  const uint i = get_global_id(0), b = get_global_id(1);
  if (i >= n_theta_i || b >= batch) return;
  const float th_o = theta_o[(first_slice + b) / n_phi_o], th_i = theta_i[i];
  __global float* out = m + (size_t)b * LOBES * n_theta_i;
  for (int p = 0; p < LOBES; ++p) out[p * n_theta_i + i] = longitudinal(prm.v[p], th_o + prm.tilt[p], th_i);
}

// global (n_phi_i, n_theta_i, batch)
__kernel void fiber_combine(__global const float* m, __global const float* nbar, const uint n_theta_i,
                            const uint n_phi_i, const uint first_slice, const uint batch, const float noise,
                            const ulong seed, __global float* rgb) {
  const uint j = get_global_id(0), i = get_global_id(1), b = get_global_id(2);
  if (j >= n_phi_i || i >= n_theta_i || b >= batch) return;
  __global const float* mb = m + (size_t)b * LOBES * n_theta_i;
  __global const float* nb = nbar + (size_t)b * CHANNELS * LOBES * n_phi_i;
  const ulong cells = (ulong)n_theta_i * n_phi_i;
  const ulong local_cell = (ulong)i * n_phi_i + j;
  const float factor = noise > 0.0f ? noise_factor((ulong)(first_slice + b) * cells + local_cell, seed, noise) : 1.0f;
  __global float* out = rgb + ((size_t)b * cells + local_cell) * CHANNELS;
  for (int c = 0; c < CHANNELS; ++c) {
    float v = 0.0f;
    for (int p = 0; p < LOBES; ++p) v += mb[p * n_theta_i + i] * nb[(c * LOBES + p) * n_phi_i + j];
    out[c] = noise > 0.0f ? v * factor : v;
  }
}
