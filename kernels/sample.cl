// Importance sampling from the fitted mixtures and the Monte Carlo estimators of the
// convergence study (docs/sampling.md), in float. CPU reference:
// include/bsdfmix/mixture.hpp (sampling, pdf, stand-in) and
// host/sampling/sample_reference.cpp (estimators); tests: tests/sample_test.cpp and
// tests/converge_test.cpp.
//
// The mixture serving one omega_o (up to 4 fitted slices blended with bilinear weights,
// thesis eq. 3.7) arrives flattened: `q` holds the blend, `comps` the components of its
// slices one after the other, 16 floats each (see COMP_* below).
//
// Random numbers: Philox4x32-10 (kernels/common.cl), counter {i lo, i hi, stream, 0}, key
// {seed lo, seed hi}; the same function as bsdfmix::mix::philox4x32_10, so sample i is the
// same everywhere.
//
// Defines: HEMISPHERE (0: fiber domain, theta in [-pi/2, pi/2], J = cos theta;
// 1: hemisphere, theta in [0, pi/2], J = sin theta); ESTIMATOR (integrate_chunks only:
// 0 us_tab, 1 us_gmm, 2 is_tab, 3 is_gmm, 4 mis_tab, 5 cdf_tab, 6 light, 7 mis_light_cdf,
// 8 mis_light_gmm, 9 product, 10 mis_product); MAP (the plane of the Gaussians, the header's
// Map: 0 (theta, phi), 1 Lambert's disk, 2 the cylinder (sin theta, phi)): the components'
// (mu_t, mu_p) and the pdf blocks are in that plane.

#ifndef HEMISPHERE
#define HEMISPHERE 0
#endif
#ifndef ESTIMATOR
#define ESTIMATOR 0
#endif
#ifndef MAP
#define MAP 0
#endif

#define S_PI 3.14159265358979323846f
#define ROUND_MAGIC 12582912.0f  // 1.5 x 2^23: (x + it) - it rounds x to an integer (|x| < 2^22)

#if HEMISPHERE
#define THETA_LO 0.0f
#else
#define THETA_LO (-0.5f * S_PI)
#endif
#define THETA_HI (0.5f * S_PI)

// Component layout (16 floats): what the draw reads.
#define COMP_MU_T 0
#define COMP_MU_P 1
#define COMP_L_TT 5
#define COMP_L_PT 6
#define COMP_L_PP 7
#define COMP_CDF 12   // cumulative component weight within its slice

// The pdf's constants (host/sampling/problem.cpp, make_query): blocks of 8 components,
// 8 rows of PDF_LANES floats each (one component per lane): mu_t, mu_p (wrapped), m, a_t, a_p, lw, r_f,
// and in row 7 lane 0 the block's image count. At (dt, dp) from the mean a component's
// term (blend weight x weight x normal density) is 2^(lw + a_t dt^2 + a_p u^2), u = dp - m dt
// the offset from the conditional mean of phi given theta; r_f is its slice's scale (the
// stand-in's f over the pdf). Padding lanes have lw = -1000.
#define PDF_ROWS 8
#ifndef PDF_LANES
#define PDF_LANES 16  // components per block: the host's QueryMixture::kLanes (8 or 16)
#endif
#define CAT_(a, b) a##b
#define CAT(a, b) CAT_(a, b)
#define VF CAT(float, PDF_LANES)
#define VI CAT(int, PDF_LANES)
#define AS_VF CAT(as_float, PDF_LANES)
#define AS_VI CAT(as_int, PDF_LANES)
#define CONVERT_VI CAT(convert_int, PDF_LANES)

// Query layout: [0] slice count, [1] rotate (phi_o added with azimuthal symmetry),
// [2..5] blend weights, [6..9] first component of each slice, [10..13] component counts,
// [14] total component count, [15] pdf blocks, [18] the first step of the component
// search (the largest power of two <= the largest count), [19..22] cumulative blend weights.
#define Q_COUNT 0
#define Q_ROTATE 1
#define Q_W 2
#define Q_FIRST 6
#define Q_N 10
#define Q_TOTAL 14
#define Q_BLOCKS 15
#define Q_STEP 18
#define Q_CUM 19
// The Lambertian base (MAP 1 only): [24..27] each slice's base share (its first cdf value),
// [28] the base's weight in the pdf (sum of blend weight x base), [29] its stand-in amplitude
// (sum of blend weight x scale x base, over f_unit).
#define Q_BASE 24
#define Q_BASE_PDF 28
#define Q_BASE_F 29

// ---- random numbers (philox4x32_10: kernels/common.cl) ------------------------------------

float4 uniforms4(const ulong index, const uint stream, const uint2 key) {
  const uint4 r = philox4x32_10((uint4)((uint)index, (uint)(index >> 32), stream, 0u), key);
  return convert_float4(r >> 8) * (1.0f / 16777216.0f);
}

// ---- angles (wrap_phi: kernels/common.cl) ---------------------------------------------

// Polynomials for |a| <= pi/4 (Taylor; error below float rounding).
float sin_poly(const float a) {
  const float a2 = a * a;
  return a * fma(a2, fma(a2, fma(a2, fma(a2, 2.7557319e-6f, -1.9841270e-4f), 8.3333333e-3f), -1.6666667e-1f), 1.0f);
}
float cos_poly(const float a) {
  const float a2 = a * a;
  return fma(a2, fma(a2, fma(a2, fma(a2, 2.4801587e-5f, -1.3888889e-3f), 4.1666667e-2f), -0.5f), 1.0f);
}

// pi/2 split in two floats: (PIO2_HI - a) is exact for a in [pi/4, pi/2], so cos and sin
// near pi/2 keep their relative accuracy.
#define PIO2_HI 1.57079637050628662109375f
#define PIO2_LO (-4.37113900018624283e-8f)

float jacobian(const float theta) {
  const float a = fabs(theta);
  const float d = (PIO2_HI - a) + PIO2_LO;
#if HEMISPHERE
  return a <= 0.25f * S_PI ? sin_poly(theta) : cos_poly(d);  // sin(theta), theta in [0, pi/2]
#else
  return a <= 0.25f * S_PI ? cos_poly(a) : sin_poly(d);  // cos(theta), |theta| <= pi/2
#endif
}

// sin and cos of 2 pi u (u in [0, 1)): quadrant by rounding, polynomials on [-pi/4, pi/4].
float2 sincos_turn(const float u) {
  const float x = u - ((u + ROUND_MAGIC) - ROUND_MAGIC);             // [-1/2, 1/2] turns
  const float j = (4.0f * x + ROUND_MAGIC) - ROUND_MAGIC;            // quadrant -2..2
  const float a = (x - 0.25f * j) * (2.0f * S_PI);
  const float s = sin_poly(a), c = cos_poly(a);
  const int q = ((int)j) & 3;
  return q == 0 ? (float2)(s, c) : q == 1 ? (float2)(c, -s) : q == 2 ? (float2)(-s, -c) : (float2)(-c, s);
}

// ln(v) for v in [2^-24, 1] (Box-Muller): v = 2^e m, m in [sqrt(1/2), sqrt(2)),
// ln m = 2 atanh((m - 1) / (m + 1)) (series to s^9: error 2e-9).
float log_unit(const float v) {
  const int i = as_int(v);
  int e = ((i >> 23) & 0xff) - 127;
  float m = as_float((i & 0x007fffff) | 0x3f800000);
  const int big = m > 1.41421356f;
  m = big ? 0.5f * m : m;
  e += big;
  const float s = (m - 1.0f) / (m + 1.0f), z = s * s;
  const float p = mad(z, mad(z, mad(z, mad(z, 1.0f / 9.0f, 1.0f / 7.0f), 0.2f), 1.0f / 3.0f), 1.0f);
  return mad((float)e, 0.693147181f, 2.0f * s * p);
}

// 2^x for x <= 127, 0 below -125 (kernels/common.cl bsdfmix_exp2).
VF exp2_v(VF x) { return select(CAT(bsdfmix_exp2, PDF_LANES)(x), (VF)(0.0f), x < -125.0f); }

// ---- the mixture ---------------------------------------------------------------------

// Sum over components of w * density, for the pdf (x) and the stand-in (y) at once; phi
// in [-pi, pi), in the slice frame (rotation removed). PDF_LANES components at a time: the phi
// image nearest each component's conditional mean (|u| <= pi), then the block's `images`
// more, nearest first: u - 2 pi s, u + 2 pi s, u - 4 pi s, .. (s = the sign of u). The host
// chose the count so that what is left out is below 2^-26 of the component's own term, or
// beyond 9 sigma (make_query). Every loop's trip count is the same for every work item.
float2 mixture_sums(__global const float* q, __global const VF* pd, const float theta, const float phi) {
  const int blocks = (int)q[Q_BLOCKS];
  VF ap = (VF)(0.0f), af = (VF)(0.0f);
  for (int b = 0; b < blocks; ++b) {
    __global const VF* r = pd + PDF_ROWS * b;
    const VF dt = theta - r[0];
    VF u = fma(-r[2], dt, phi - r[1]);
    u = fma((u * (0.5f / S_PI) + ROUND_MAGIC) - ROUND_MAGIC, -2.0f * S_PI, u);  // |u| <= pi
    const VF xm = fma(r[3] * dt, dt, r[5]);
    const VF a = r[4];
    VF t = exp2_v(fma(a * u, u, xm));
    const int images = (int)r[7].s0;
    const VF s = copysign((VF)(2.0f * S_PI), u);
    for (int j = 1; j <= images; ++j) {
      const float n = (float)((j + 1) >> 1);
      const VF v = (j & 1) ? u - n * s : u + n * s;
      t += exp2_v(fma(a * v, v, xm));
    }
    ap += t;
    af = fma(t, r[6], af);
  }
  float2 out = (float2)(CAT(sum_lanes, PDF_LANES)(ap), CAT(sum_lanes, PDF_LANES)(af));
#if MAP == 1
  const float dome = fmax(1.0f - 0.5f * fma(theta, theta, phi * phi), 0.0f) * (1.0f / S_PI);  // cos / pi at (x, y)
  out += (float2)(q[Q_BASE_PDF], q[Q_BASE_F]) * dome;
#endif
  return out;
}

bool theta_inside(const float theta) { return theta >= THETA_LO && theta <= THETA_HI; }

// The map's point (x, y) of direction (theta, phi) (the header's to_map).
float2 plane_of(const float theta, const float phi) {
#if MAP == 1
  const float r = 2.0f * sin(0.5f * theta);
  return (float2)(r * cos(phi), r * sin(phi));
#elif MAP == 2
  return (float2)(sin(theta), phi);
#else
  return (float2)(theta, phi);
#endif
}

// The direction (theta, phi) of map point (x, y) (the header's from_map); theta past
// THETA_HI when the point leaves the domain.
float2 direction_of(const float x, const float y) {
#if MAP == 1
  const float r2 = fma(x, x, y * y);
  if (!(r2 <= 2.0f)) return (float2)(THETA_HI + 1.0f, 0.0f);
  return (float2)(2.0f * asin(fmin(0.5f * sqrt(r2), 1.0f)), r2 > 0.0f ? atan2(y, x) : 0.0f);
#elif MAP == 2
  if (!(fabs(x) <= 1.0f)) return (float2)(THETA_HI + 1.0f, 0.0f);
  return (float2)(asin(x), y);
#else
  return (float2)(x, y);
#endif
}

// (pdf, stand-in f [cos]) per steradian at (theta, phi), phi in the slice frame: the
// mixture's sums at the map's point; on (theta, phi) over the Jacobian (0 where it is 0).
float2 mixture_omega(__global const float* q, __global const VF* pd, const float theta, const float phi) {
#if MAP
  const float2 p = plane_of(theta, phi);
  return mixture_sums(q, pd, p.x, wrap_phi(p.y));
#else
  const float j = jacobian(theta);
  return j > 0.0f ? mixture_sums(q, pd, theta, phi) / j : (float2)(0.0f, 0.0f);
#endif
}

// pdf per steradian of the mixture sampler at (theta, phi) (phi in the world frame).
float mixture_pdf_omega(__global const float* q, __global const VF* pd, const float theta, const float phi) {
  if (!theta_inside(theta)) return 0.0f;
  return mixture_omega(q, pd, theta, wrap_phi(phi - q[Q_ROTATE])).x;
}

// Draws a point from the blended mixture with uniforms u (u.x slice, u.y component,
// u.zw the normal pair). Returns (theta, phi); phi wrapped, in the world frame.
float2 mixture_draw(__global const float* q, __global const float16* comps, const float4 u) {
  const int count = (int)q[Q_COUNT];
  // the slice: how many cumulative weights u.x has passed (the last slice takes the rest)
  const int k = (count > 1 && u.x >= q[Q_CUM]) + (count > 2 && u.x >= q[Q_CUM + 1]) +
                (count > 3 && u.x >= q[Q_CUM + 2]);
  const int first = (int)q[Q_FIRST + k], n = (int)q[Q_N + k];
#if MAP == 1
  if (u.y < q[Q_BASE + k] || n == 0) {  // the Lambertian base: cosine-weighted (Malley)
    return (float2)(asin(fmin(sqrt(u.z), 1.0f)), wrap_phi(fma(2.0f * S_PI, u.w, -S_PI) + q[Q_ROTATE]));
  }
#endif
  // upper_bound of u.y in the slice's cumulative weights, branch-free: lo = how many are <= u.y
  __global const float* cdf = (__global const float*)(comps + first) + COMP_CDF;
  int lo = 0;
  for (int step = (int)q[Q_STEP]; step > 0; step >>= 1) {
    const int j = lo + step;
    lo = (j <= n && cdf[16 * (min(j, n) - 1)] <= u.y) ? j : lo;
  }
  const float16 g = comps[first + min(lo, n - 1)];
  const float r = sqrt(-2.0f * log_unit(1.0f - u.z));
  const float2 sc = sincos_turn(u.w);
  const float z0 = r * sc.y, z1 = r * sc.x;
#if MAP
  const float2 d = direction_of(mad(g.s5, z0, g.s0), wrap_phi(g.s1 + g.s6 * z0 + g.s7 * z1));
  return (float2)(d.x, wrap_phi(d.y + q[Q_ROTATE]));
#else
  const float theta = mad(g.s5, z0, g.s0);
  const float phi = wrap_phi(g.s1 + g.s6 * z0 + g.s7 * z1 + q[Q_ROTATE]);
  return (float2)(theta, phi);
#endif
}

// `n` samples first..first+n-1 of `stream`: (theta, phi, pdf_omega, valid).
__kernel void sample_mixture(__global const float* q, __global const float16* comps, __global const VF* pd,
                             const uint key0, const uint key1, const uint stream, const ulong first, const uint n,
                             __global float4* out) {
  const uint i = get_global_id(0);
  if (i >= n) return;
  const float4 u = uniforms4(first + i, stream, (uint2)(key0, key1));
  const float2 p = mixture_draw(q, comps, u);
  const float pdf = mixture_pdf_omega(q, pd, p.x, p.y);
  const float valid = (theta_inside(p.x) && pdf > 0.0f) ? 1.0f : 0.0f;
  out[i] = (float4)(p.x, p.y, valid > 0.0f ? pdf : 0.0f, valid);
}

// pdf_omega and the stand-in f at n directions (theta, phi) (world phi): out (pdf, f).
__kernel void eval_mixture(__global const float* q, __global const VF* pd, __global const float2* dirs,
                           const uint n, __global float2* out) {
  const uint i = get_global_id(0);
  if (i >= n) return;
  const float theta = dirs[i].x, phi = dirs[i].y;
  float2 r = (float2)(0.0f, 0.0f);
  if (theta_inside(theta)) {
    r = mixture_omega(q, pd, theta, wrap_phi(phi - q[Q_ROTATE]));
#if HEMISPHERE
    r.y = theta < THETA_HI ? r.y / cos(theta) : 0.0f;  // f is 0 at the horizon (the header's f_inside)
#endif
  }
  out[i] = r;
}

// ---- the estimators -------------------------------------------------------------------

// Table slice geometry: [0] theta of the first cell's lower edge, [1] dtheta, [2] n_theta,
// [3] phi of the first cell's lower edge, [4] dphi, [5] n_phi, [6] uniform fraction (mis),
// [7] light fraction (mis_light_*), [8] product and [9] light fractions (mis_product),
// [10] 1: the power heuristic, 0: the balance heuristic.
#define T_LIGHT 7
#define T_PROD 8
#define T_PROD_LIGHT 9
#define T_POWER 10
#define T_TH0 0
#define T_DTH 1
#define T_NTH 2
#define T_PH0 3
#define T_DPH 4
#define T_NPH 5
#define T_ALPHA 6

// Scene layout (see host/converge/scene.hpp): [0..8] frame (axis, e1, e2),
// [9] constant, [10] lobe count, [11..50] lobes (dir xyz, kappa, radiance) x 8,
// [51..56] gradient (up xyz, zenith, horizon, ground), [57] gradient on,
// [58] env width, [59] env height, [60] env scale (0 = none).
#define SC_CONST 9
#define SC_NLOBES 10
#define SC_LOBES 11
#define SC_GRAD 51
#define SC_GRAD_ON 57
#define SC_ENV_W 58
#define SC_ENV_H 59
#define SC_ENV_SCALE 60

float3 to_world(__global const float* sc, const float theta, const float phi) {
  const float3 a = (float3)(sc[0], sc[1], sc[2]), e1 = (float3)(sc[3], sc[4], sc[5]), e2 = (float3)(sc[6], sc[7], sc[8]);
#if HEMISPHERE
  return cos(theta) * a + sin(theta) * (cos(phi) * e1 + sin(phi) * e2);
#else
  return sin(theta) * a + cos(theta) * (cos(phi) * e1 + sin(phi) * e2);
#endif
}

float envmap_lookup(__global const float* sc, __global const float* env, const float3 w) {
  const int W = (int)sc[SC_ENV_W], H = (int)sc[SC_ENV_H];
  const float u = (atan2(w.y, w.x) + S_PI) / (2.0f * S_PI) * (float)W - 0.5f;
  const float v = acos(clamp(w.z, -1.0f, 1.0f)) / S_PI * (float)H - 0.5f;
  const float fu = floor(u), fv = floor(v);
  const float au = u - fu, av = v - fv;
  int x0 = (int)fu, y0 = (int)fv;
  int x1 = x0 + 1, y1 = y0 + 1;
  x0 = (x0 % W + W) % W;
  x1 = (x1 % W + W) % W;
  y0 = clamp(y0, 0, H - 1);
  y1 = clamp(y1, 0, H - 1);
  const float top = (1.0f - au) * env[y0 * W + x0] + au * env[y0 * W + x1];
  const float bot = (1.0f - au) * env[y1 * W + x0] + au * env[y1 * W + x1];
  return (1.0f - av) * top + av * bot;
}

// Incident radiance from direction (theta, phi) of the table's frame.
float radiance(__global const float* sc, __global const float* env, const float theta, const float phi) {
  const float3 w = to_world(sc, theta, phi);
  float L = sc[SC_CONST];
  const int nl = (int)sc[SC_NLOBES];
  for (int i = 0; i < nl; ++i) {
    __global const float* lb = sc + SC_LOBES + 5 * i;
    const float3 d = w - (float3)(lb[0], lb[1], lb[2]);
    L += lb[4] * exp(-0.5f * lb[3] * dot(d, d));  // exp(kappa (cos - 1)), 1 - cos = |w - d|^2 / 2
  }
  if (sc[SC_GRAD_ON] > 0.0f) {
    const float t = dot(w, (float3)(sc[SC_GRAD], sc[SC_GRAD + 1], sc[SC_GRAD + 2]));
    L += t >= 0.0f ? sc[SC_GRAD + 4] + (sc[SC_GRAD + 3] - sc[SC_GRAD + 4]) * t
                   : sc[SC_GRAD + 4] + (sc[SC_GRAD + 4] - sc[SC_GRAD + 5]) * t;
  }
  if (sc[SC_ENV_SCALE] != 0.0f) L += sc[SC_ENV_SCALE] * envmap_lookup(sc, env, w);
  return L;
}

// The table as f: the value of the cell holding (theta, phi_local); 0 outside the cells.
float table_f(__global const float* geo, __global const float* f, const float theta, const float phi_local) {
  const int i = (int)floor((theta - geo[T_TH0]) / geo[T_DTH]);
  const int nth = (int)geo[T_NTH], nph = (int)geo[T_NPH];
  if (i < 0 || i >= nth) return 0.0f;
  int j = (int)floor((phi_local - geo[T_PH0]) / geo[T_DPH]);
  j = (j % nph + nph) % nph;
  return f[i * nph + j];
}

float cos_factor(const float theta) {
#if HEMISPHERE
  return cos(theta);
#else
  return 1.0f;
#endif
}

// Uniform direction over the domain from (u, v): returns (theta, phi); pdf 1/(4 pi) or 1/(2 pi).
float2 uniform_draw(const float u, const float v) {
#if HEMISPHERE
  const float theta = acos(1.0f - u);
#else
  const float theta = asin(clamp(2.0f * u - 1.0f, -1.0f, 1.0f));
#endif
  return (float2)(theta, 2.0f * S_PI * v - S_PI);
}

#if HEMISPHERE
#define UNIFORM_PDF (1.0f / (2.0f * S_PI))
#else
#define UNIFORM_PDF (1.0f / (4.0f * S_PI))
#endif

// First index i in [0, n) with cdf[i + 1] > u (cdf[0] = 0, cdf[n] = 1): the cell holding u.
int cdf_find(__global const float* cdf, const int n, const float u) {
  int lo = 0, hi = n;  // search in cdf[1..n]
  while (lo < hi) {
    const int mid = (lo + hi) / 2;
    if (cdf[mid + 1] > u) hi = mid;
    else lo = mid + 1;
  }
  return min(lo, n - 1);
}

// ---- light sampling (host/sampling/light_sampler.hpp; LightSampler::pack) ---------------
// [0] p_const, [1] p_grad, [2] p_env, [3] lobe count, [4] G (the gradient's integral over
// t), [5] its share below the horizon, [6] map width, [7] height, [8..15] p_lobe,
// [16..23] lobe peak densities, [24..71] lobe bases (t1, t2: 6 floats per lobe),
// [72..77] the up axis's basis, [78] the last term present; from [128]: the map's marginal [H + 1], conditionals
// [H][W + 1] and pixel densities [H][W].
#define LS_HEADER 128

float3 world_dir(const float z, const float az_cos, const float az_sin, const float3 n, const float3 t1,
                 const float3 t2) {
  const float r = sqrt(fmax(0.0f, 1.0f - z * z));
  return z * n + r * (az_cos * t1 + az_sin * t2);
}

// t in [0, 1] with density proportional to a + (b - a) t (LightSampler's linear_draw).
float linear_draw(const float a, const float b, const float u) {
  const float r = sqrt(fmax(mad(u, b * b - a * a, a * a), 0.0f));
  return a + r > 0.0f ? clamp(u * (a + b) / (a + r), 0.0f, 1.0f) : u;
}

// A world direction from the lighting's terms: u.x picks the term, u.yzw the point.
float3 light_draw(__global const float* ls, __global const float* sc, const float4 u) {
  // the term: the first whose cumulative probability passes u.x (0 constant, 1 gradient,
  // 2 map, 3 + k lobe k); a u.x past the rounded sum goes to the last term present ([78])
  const int nl = (int)ls[3];
  int term = -1;
  float acc = 0.0f;
  for (int k = 0; k < 3 + nl && term < 0; ++k) {
    const float p = k < 3 ? ls[k] : ls[8 + k - 3];
    acc += p;
    if (u.x < acc && p > 0.0f) term = k;
  }
  if (term < 0) term = (int)ls[78];
  if (term == 0) {
    const float z = 1.0f - 2.0f * u.z;
    const float2 cs = sincos_turn(u.w);
    return world_dir(z, cs.y, cs.x, (float3)(0.0f, 0.0f, 1.0f), (float3)(1.0f, 0.0f, 0.0f), (float3)(0.0f, 1.0f, 0.0f));
  }
  if (term == 1) {
    const float t = u.y < ls[5] ? -linear_draw(sc[SC_GRAD + 4], sc[SC_GRAD + 5], u.z)
                                : linear_draw(sc[SC_GRAD + 4], sc[SC_GRAD + 3], u.z);
    const float2 cs = sincos_turn(u.w);
    return world_dir(t, cs.y, cs.x, (float3)(sc[SC_GRAD], sc[SC_GRAD + 1], sc[SC_GRAD + 2]),
                     (float3)(ls[72], ls[73], ls[74]), (float3)(ls[75], ls[76], ls[77]));
  }
  if (term == 2) {
    const int W = (int)ls[6], H = (int)ls[7];
    __global const float* marg = ls + LS_HEADER;
    const int y = cdf_find(marg, H, u.y);
    __global const float* c = marg + (H + 1) + y * (W + 1);
    const int x = cdf_find(c, W, u.z);
    const float fx = clamp((u.z - c[x]) / fmax(c[x + 1] - c[x], 1e-30f), 0.0f, 1.0f);
    const float za = cospi((float)y / (float)H), zb = cospi((float)(y + 1) / (float)H);
    const float z = mad(u.w, zb - za, za);
    const float az = -S_PI + 2.0f * S_PI * ((float)x + fx) / (float)W;
    return world_dir(z, cos(az), sin(az), (float3)(0.0f, 0.0f, 1.0f), (float3)(1.0f, 0.0f, 0.0f),
                     (float3)(0.0f, 1.0f, 0.0f));
  }
  const int k = term - 3;
  __global const float* lb = sc + SC_LOBES + 5 * k;
  const float kappa = lb[3], v = 1.0f - u.y;  // (0, 1]
  const float omc = fmin(2.0f, -log(v + (1.0f - v) * exp(-2.0f * kappa)) / kappa);
  const float st = sqrt(fmax(0.0f, omc * (2.0f - omc)));
  const float2 cs = sincos_turn(u.z);
  const float3 t1 = (float3)(ls[24 + 6 * k], ls[25 + 6 * k], ls[26 + 6 * k]);
  const float3 t2 = (float3)(ls[27 + 6 * k], ls[28 + 6 * k], ls[29 + 6 * k]);
  return (1.0f - omc) * (float3)(lb[0], lb[1], lb[2]) + st * (cs.y * t1 + cs.x * t2);
}

// The density per steradian of light_draw at the world direction w.
float light_pdf(__global const float* ls, __global const float* sc, const float3 w) {
  float p = ls[0] * (1.0f / (4.0f * S_PI));
  if (ls[1] > 0.0f) {
    const float t = dot(w, (float3)(sc[SC_GRAD], sc[SC_GRAD + 1], sc[SC_GRAD + 2]));
    const float g = t >= 0.0f ? sc[SC_GRAD + 4] + (sc[SC_GRAD + 3] - sc[SC_GRAD + 4]) * t
                              : sc[SC_GRAD + 4] + (sc[SC_GRAD + 4] - sc[SC_GRAD + 5]) * t;
    p += ls[1] * g / (2.0f * S_PI * ls[4]);
  }
  if (ls[2] > 0.0f) {
    const int W = (int)ls[6], H = (int)ls[7];
    const int x = clamp((int)floor((atan2(w.y, w.x) + S_PI) / (2.0f * S_PI) * (float)W), 0, W - 1);
    const int y = clamp((int)floor(acos(clamp(w.z, -1.0f, 1.0f)) / S_PI * (float)H), 0, H - 1);
    p += ls[2] * ls[LS_HEADER + (H + 1) + H * (W + 1) + y * W + x];
  }
  const int nl = (int)ls[3];
  for (int k = 0; k < nl; ++k) {
    __global const float* lb = sc + SC_LOBES + 5 * k;
    const float3 d = w - (float3)(lb[0], lb[1], lb[2]);
    p += ls[8 + k] * ls[16 + k] * exp(-0.5f * lb[3] * dot(d, d));
  }
  return p;
}

// World direction to the table's (theta, phi).
float2 to_slice(__global const float* sc, const float3 w) {
  const float3 a = (float3)(sc[0], sc[1], sc[2]), e1 = (float3)(sc[3], sc[4], sc[5]), e2 = (float3)(sc[6], sc[7], sc[8]);
  const float c = clamp(dot(w, a), -1.0f, 1.0f);
#if HEMISPHERE
  const float theta = acos(c);
#else
  const float theta = asin(c);
#endif
  return (float2)(theta, wrap_phi(atan2(dot(w, e2), dot(w, e1))));
}

// ---- the table CDF as a technique ------------------------------------------------------

// Draws (theta, phi world) by the table CDF (cdf_tab's draw); .z = 0 when the cell is empty.
float3 cdf_draw(__global const float* geo, __global const float* marg, __global const float* cond, const float rotate,
                const float4 u) {
  const int nth = (int)geo[T_NTH], nph = (int)geo[T_NPH];
  const int i = cdf_find(marg, nth, u.x);
  __global const float* row = cond + i * (nph + 1);
  const int jc = cdf_find(row, nph, u.y);
  const float p_cell = (marg[i + 1] - marg[i]) * (row[jc + 1] - row[jc]);
  const float a = fmax(geo[T_TH0] + geo[T_DTH] * (float)i, THETA_LO);
  const float b = fmin(geo[T_TH0] + geo[T_DTH] * (float)(i + 1), THETA_HI);
#if HEMISPHERE
  const float sa = sin(a) * sin(a), sb = sin(b) * sin(b);
  const float theta = asin(sqrt(clamp(sa + u.z * (sb - sa), 0.0f, 1.0f)));
#else
  const float sa = sin(a), sb = sin(b);
  const float theta = asin(clamp(sa + u.z * (sb - sa), -1.0f, 1.0f));
#endif
  const float phi = wrap_phi(geo[T_PH0] + geo[T_DPH] * ((float)jc + u.w) + rotate);
  return (float3)(theta, phi, p_cell > 0.0f ? 1.0f : 0.0f);
}

// Its density per steradian at (theta, phi local): P_cell c(theta) / integral of c J over the cell.
float cdf_pdf(__global const float* geo, __global const float* marg, __global const float* cond, const float theta,
              const float phi_local) {
  const int nth = (int)geo[T_NTH], nph = (int)geo[T_NPH];
  const int i = (int)floor((theta - geo[T_TH0]) / geo[T_DTH]);
  if (i < 0 || i >= nth || !theta_inside(theta)) return 0.0f;
  int j = (int)floor((phi_local - geo[T_PH0]) / geo[T_DPH]);
  j = (j % nph + nph) % nph;
  __global const float* row = cond + i * (nph + 1);
  const float p_cell = (marg[i + 1] - marg[i]) * (row[j + 1] - row[j]);
  const float a = fmax(geo[T_TH0] + geo[T_DTH] * (float)i, THETA_LO);
  const float b = fmin(geo[T_TH0] + geo[T_DTH] * (float)(i + 1), THETA_HI);
#if HEMISPHERE
  const float w = 0.5f * (sin(b) * sin(b) - sin(a) * sin(a)) * geo[T_DPH];
#else
  const float w = (sin(b) - sin(a)) * geo[T_DPH];
#endif
  return w > 0.0f ? p_cell * cos_factor(theta) / w : 0.0f;
}

// One-sample MIS weight (the host's mis_weight): balance 1 / sum c p; power c_s p_s / sum (c p)^2.
float mis_weight(const float3 c, const float3 pdf, const int chosen, const float power) {
  const float3 cp = c * pdf;
  const float s1 = cp.x + cp.y + cp.z;
  if (!(s1 > 0.0f)) return 0.0f;
  if (power == 0.0f) return 1.0f / s1;
  const float sel = chosen == 0 ? cp.x : chosen == 1 ? cp.y : cp.z;
  return sel / dot(cp, cp);
}

// The inputs every estimator may read (integrate_chunks' buffers): the mixture (q, comps,
// pd), the table (geo, f) and its CDF (marg, cond), the scene (sc, env), the product
// mixture (q2, comps2, pd2), the light sampler (ls), and the sample's uniforms u.
#define ESTIMATE_PARAMS                                                                                     \
  __global const float* q, __global const float16* comps, __global const VF* pd, __global const float* geo, \
      __global const float* f, __global const float* marg, __global const float* cond,                       \
      __global const float* sc, __global const float* env, __global const float* q2,                       \
      __global const float16* comps2, __global const VF* pd2, __global const float* ls, const float4 u
#define ESTIMATE_ARGS q, comps, pd, geo, f, marg, cond, sc, env, q2, comps2, pd2, ls, u

// The estimate L f c / pdf at the direction d (theta, phi world) drawn with density pdf
// per steradian (fv: f there); 0 where pdf is not positive.
float by_pdf(__global const float* sc, __global const float* env, const float2 d, const float fv, const float pdf) {
  if (!(pdf > 0.0f)) return 0.0f;
  return radiance(sc, env, d.x, d.y) * fv * cos_factor(d.x) / pdf;
}

#if ESTIMATOR == 0 || ESTIMATOR == 1
// One estimate of L_o by us_tab, us_gmm: directions uniform over the domain.
float estimate_uniform(ESTIMATE_PARAMS) {
  const float rotate = q[Q_ROTATE];
  const float2 d = uniform_draw(u.z, u.w);
#if ESTIMATOR == 0
  const float fv = table_f(geo, f, d.x, wrap_phi(d.y - rotate));
#else
  float fv = mixture_omega(q, pd, d.x, wrap_phi(d.y - rotate)).y;
#if HEMISPHERE
  fv = fv != 0.0f ? fv / cos(d.x) : 0.0f;
#endif
#endif
  if (fv == 0.0f) return 0.0f;
  return radiance(sc, env, d.x, d.y) * fv * cos_factor(d.x) / UNIFORM_PDF;
}
#elif ESTIMATOR == 2 || ESTIMATOR == 3
// One estimate of L_o by is_tab, is_gmm: directions drawn from the mixture.
float estimate_mixture(ESTIMATE_PARAMS) {
  const float rotate = q[Q_ROTATE];
  const float2 d = mixture_draw(q, comps, u);
  if (!theta_inside(d.x)) return 0.0f;
  const float2 s = mixture_omega(q, pd, d.x, wrap_phi(d.y - rotate));
  if (!(s.x > 0.0f)) return 0.0f;
#if ESTIMATOR == 2
  const float fv = table_f(geo, f, d.x, wrap_phi(d.y - rotate));
  if (fv == 0.0f) return 0.0f;
  return radiance(sc, env, d.x, d.y) * fv * cos_factor(d.x) / s.x;
#else
  // the stand-in: f c = sum w scale p_omega, so f c / pdf_omega = sums.y / sums.x
  return radiance(sc, env, d.x, d.y) * s.y / s.x;
#endif
}
#elif ESTIMATOR == 4
// One estimate of L_o by mis_tab: the mixture with a defensive uniform share alpha.
float estimate_defensive(ESTIMATE_PARAMS) {
  const float rotate = q[Q_ROTATE];
  const float alpha = geo[T_ALPHA];
  float2 d;
  if (u.x < alpha) {
    d = uniform_draw(u.z, u.w);
  } else {
    d = mixture_draw(q, comps, (float4)((u.x - alpha) / (1.0f - alpha), u.y, u.z, u.w));
    if (!theta_inside(d.x)) return 0.0f;
  }
  const float fv = table_f(geo, f, d.x, wrap_phi(d.y - rotate));
  if (fv == 0.0f) return 0.0f;
  const float pm = mixture_omega(q, pd, d.x, wrap_phi(d.y - rotate)).x;
  const float pdf = alpha * UNIFORM_PDF + (1.0f - alpha) * pm;
  return by_pdf(sc, env, d, fv, pdf);
}
#elif ESTIMATOR == 5
// One estimate of L_o by cdf_tab: the table CDF.
float estimate_cdf(ESTIMATE_PARAMS) {
  const float rotate = q[Q_ROTATE];
  // piecewise-constant 2D CDF over the cells, exact within a cell: theta drawn with
  // density proportional to c(theta) J(theta), phi uniform
  const float3 d = cdf_draw(geo, marg, cond, rotate, u);
  if (d.z == 0.0f) return 0.0f;
  const float pdf = cdf_pdf(geo, marg, cond, d.x, wrap_phi(d.y - rotate));
  if (!(pdf > 0.0f)) return 0.0f;
  return radiance(sc, env, d.x, d.y) * table_f(geo, f, d.x, wrap_phi(d.y - rotate)) * cos_factor(d.x) / pdf;
}
#elif ESTIMATOR == 6
// One estimate of L_o by light: the light sampler.
float estimate_light(ESTIMATE_PARAMS) {
  const float rotate = q[Q_ROTATE];
  const float2 d = to_slice(sc, light_draw(ls, sc, u));
  if (!theta_inside(d.x)) return 0.0f;
  const float fv = table_f(geo, f, d.x, wrap_phi(d.y - rotate));
  if (fv == 0.0f) return 0.0f;
  const float pdf = light_pdf(ls, sc, to_world(sc, d.x, d.y));
  return by_pdf(sc, env, d, fv, pdf);
}
#elif ESTIMATOR == 9
// One estimate of L_o by product: the product mixture.
float estimate_product(ESTIMATE_PARAMS) {
  const float rotate = q[Q_ROTATE];
  const float2 d = mixture_draw(q2, comps2, u);
  if (!theta_inside(d.x)) return 0.0f;
  const float fv = table_f(geo, f, d.x, wrap_phi(d.y - rotate));
  if (fv == 0.0f) return 0.0f;
  const float pdf = mixture_pdf_omega(q2, pd2, d.x, d.y);
  return by_pdf(sc, env, d, fv, pdf);
}
#else
// One estimate of L_o by mis_light_cdf, mis_light_gmm, mis_product: one-sample MIS.
float estimate_mis(ESTIMATE_PARAMS) {
  const float rotate = q[Q_ROTATE];
  // one-sample MIS over two or three techniques, picked by u.x with the fractions c; the
  // remainder of u.x is the technique's own u.x
#if ESTIMATOR == 7
  const float3 c = (float3)(geo[T_LIGHT], 1.0f - geo[T_LIGHT], 0.0f);  // light, table CDF
#elif ESTIMATOR == 8
  const float3 c = (float3)(geo[T_LIGHT], (1.0f - geo[T_LIGHT]) * (1.0f - geo[T_ALPHA]),
                            (1.0f - geo[T_LIGHT]) * geo[T_ALPHA]);  // light, mixture, uniform
#else
  const float3 c = (float3)(geo[T_PROD], geo[T_PROD_LIGHT], 1.0f - geo[T_PROD] - geo[T_PROD_LIGHT]);  // product, light, uniform
#endif
  const int k = (u.x >= c.x) + (c.z > 0.0f && u.x >= c.x + c.y);
  const float lo = k == 0 ? 0.0f : k == 1 ? c.x : c.x + c.y;
  const float ck = k == 0 ? c.x : k == 1 ? c.y : c.z;
  const float4 v = (float4)(clamp((u.x - lo) / ck, 0.0f, 0.99999994f), u.y, u.z, u.w);
#if ESTIMATOR == 10
  const int light_k = 1;
#else
  const int light_k = 0;
#endif
  float2 d;
  if (k == light_k) {
    d = to_slice(sc, light_draw(ls, sc, v));
  } else if (k == 2) {
    d = uniform_draw(u.z, u.w);
  } else {
#if ESTIMATOR == 7
    const float3 dc = cdf_draw(geo, marg, cond, rotate, v);
    if (dc.z == 0.0f) return 0.0f;
    d = dc.xy;
#elif ESTIMATOR == 8
    d = mixture_draw(q, comps, v);
#else
    d = mixture_draw(q2, comps2, v);
#endif
  }
  if (!theta_inside(d.x)) return 0.0f;
  const float pl = wrap_phi(d.y - rotate);
  const float fv = table_f(geo, f, d.x, pl);
  if (fv == 0.0f) return 0.0f;
  const float pli = light_pdf(ls, sc, to_world(sc, d.x, d.y));
#if ESTIMATOR == 7
  const float3 pdf = (float3)(pli, cdf_pdf(geo, marg, cond, d.x, pl), 0.0f);
#elif ESTIMATOR == 8
  const float pm = mixture_omega(q, pd, d.x, pl).x;
  const float3 pdf = (float3)(pli, pm, UNIFORM_PDF);
#else
  const float3 pdf = (float3)(mixture_pdf_omega(q2, pd2, d.x, d.y), pli, UNIFORM_PDF);
#endif
  const float w = mis_weight(c, pdf, k, geo[T_POWER]);
  return w > 0.0f ? radiance(sc, env, d.x, d.y) * fv * cos_factor(d.x) * w : 0.0f;
}
#endif

// One estimate of L_o with uniforms u, by the estimator ESTIMATOR.
float estimate(ESTIMATE_PARAMS) {
#if ESTIMATOR == 0 || ESTIMATOR == 1
  return estimate_uniform(ESTIMATE_ARGS);
#elif ESTIMATOR == 2 || ESTIMATOR == 3
  return estimate_mixture(ESTIMATE_ARGS);
#elif ESTIMATOR == 4
  return estimate_defensive(ESTIMATE_ARGS);
#elif ESTIMATOR == 5
  return estimate_cdf(ESTIMATE_ARGS);
#elif ESTIMATOR == 6
  return estimate_light(ESTIMATE_ARGS);
#elif ESTIMATOR == 9
  return estimate_product(ESTIMATE_ARGS);
#else
  return estimate_mis(ESTIMATE_ARGS);
#endif
}

// Work item (run r, chunk c) sums the estimates of samples c*chunk .. (c+1)*chunk-1 of run
// r (Kahan). Sample n of run r uses counter {n lo, n hi, stream, r}: independent of the
// chunking. Chunk 0 also writes the prefix sums at N = 1, 2, 4, .., chunk/2.
__kernel void integrate_chunks(__global const float* q, __global const float16* comps, __global const VF* pd,
                               __global const float* geo,
                               __global const float* f, __global const float* marg, __global const float* cond,
                               __global const float* sc, __global const float* env, __global const float* q2,
                               __global const float16* comps2, __global const VF* pd2, __global const float* ls,
                               const uint key0,
                               const uint key1, const uint stream, const uint runs, const uint chunks,
                               const uint chunk, const uint levels, __global float* sums,
                               __global float* prefix) {
  const uint gid = get_global_id(0);
  if (gid >= runs * chunks) return;
  const uint r = gid / chunks, c = gid % chunks;
  const uint2 key = (uint2)(key0, key1);
  float s = 0.0f, comp = 0.0f;
  uint next = 1;
  int level = 0;
  for (uint k = 0; k < chunk; ++k) {
    const ulong n = (ulong)c * chunk + k;
    const uint4 bits = philox4x32_10((uint4)((uint)n, (uint)(n >> 32), stream, r), key);
    const float4 u = convert_float4(bits >> 8) * (1.0f / 16777216.0f);
    const float e = estimate(q, comps, pd, geo, f, marg, cond, sc, env, q2, comps2, pd2, ls, u);
    const float y = e - comp;
    const float t = s + y;
    comp = (t - s) - y;
    s = t;
    if (c == 0 && k + 1 == next && level < (int)levels) {
      prefix[r * levels + level] = s;
      ++level;
      next <<= 1;
    }
  }
  sums[gid] = s;
}
