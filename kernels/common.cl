// Primitives shared by every kernel program: host/device/program.cpp puts this file in
// front of each kernels/<name>.cl it builds (never built as a program of its own), so it
// uses no macro of any one program (real_t, floatv, VEC, K_MAX, PDF_LANES, ..) and defines
// only names starting with bsdfmix_/BSDFMIX_ or the functions below. Test:
// tests/rng_test.cpp (Philox against the header and Random123, wrap_phi against the
// header, the lane sums).

#define BSDFMIX_PI_F 3.14159265358979323846f

// ---- Philox4x32-10 ----------------------------------------------------------------------

// Philox4x32-10 (Salmon et al. 2011), the generator of Random123's philox4x32 and of
// bsdfmix::mix::philox4x32_10 (include/bsdfmix/mixture.hpp): counter c, key k.
uint4 philox4x32_10(uint4 c, uint2 k) {
  for (int r = 0; r < 10; ++r) {
    if (r > 0) {
      k.x += 0x9E3779B9u;
      k.y += 0xBB67AE85u;
    }
    const uint hi0 = mul_hi(0xD2511F53u, c.x), lo0 = 0xD2511F53u * c.x;
    const uint hi1 = mul_hi(0xCD9E8D57u, c.z), lo1 = 0xCD9E8D57u * c.z;
    c = (uint4)(hi1 ^ c.y ^ k.x, lo1, hi0 ^ c.w ^ k.y, lo0);
  }
  return c;
}

// ---- the phi wrap and the lane sums, for any floating type ---------------------------------
//
// Each is written once as a macro over its type T (and the name suffix S); float is
// instantiated here, double by a program that enables cl_khr_fp64 (kernels/em.cl under
// EM_FP64), since this file must build on devices without doubles.

// T wrap_phiS(T phi): phi wrapped into [-pi, pi) (PI: pi in T), as the header's wrap_phi:
// a result that rounds to +pi is -pi.
#define BSDFMIX_WRAP_PHI(T, S, PI)                                 \
  T wrap_phi##S(const T phi) {                                     \
    const T r = phi - ((T)2 * (PI)) * floor((phi + (PI)) / ((T)2 * (PI))); \
    return r >= (PI) ? -(PI) : r;                                  \
  }

// T sum_lanesNS(TN v) for N = 2, 4, 8, 16: the sum of the lanes of a vector as a tree of
// vector adds (halves added until two lanes are left), not a loop over lanes.
#define BSDFMIX_CAT_(a, b) a##b
#define BSDFMIX_CAT(a, b) BSDFMIX_CAT_(a, b)
#define BSDFMIX_LANE_SUMS(T, S)                                                                       \
  T sum_lanes2##S(const BSDFMIX_CAT(T, 2) v) { return v.x + v.y; }                                    \
  T sum_lanes4##S(const BSDFMIX_CAT(T, 4) v) { return sum_lanes2##S(v.lo + v.hi); }                    \
  T sum_lanes8##S(const BSDFMIX_CAT(T, 8) v) { return sum_lanes4##S(v.lo + v.hi); }                    \
  T sum_lanes16##S(const BSDFMIX_CAT(T, 16) v) { return sum_lanes8##S(v.lo + v.hi); }

BSDFMIX_WRAP_PHI(float, , BSDFMIX_PI_F)
BSDFMIX_LANE_SUMS(float, )

// ---- 2^x ---------------------------------------------------------------------------------
//
// T bsdfmix_exp2S(T x) for T = float (S empty), float4, float8, float16 (S = 4, 8, 16): 2^x
// for x in [-125, 127], x clamped to that range (callers zero what lies below their own
// cutoff); bsdfmix_exp2_inS without the clamp, for callers that keep x in range or discard
// what lies outside. x = n + f with n = rint(x) (adding and removing 1.5 x 2^23, which leaves
// n in the low mantissa bits), f in [-1/2, 1/2]; 2^f by the degree-5 minimax polynomial of
// the relative error (2.2e-7 at most with the float coefficients and FMAs, measured on 2e6
// points; as accurate as degree 6 in float) and n added to its exponent bits. No library
// call and no rounding mode: the fitting (kernels/fit_common.cl exp2_neg) and sampling
// (kernels/sample.cl) kernels share it.
#define BSDFMIX_EXP2(T, TI, S)                                                                      \
  T bsdfmix_exp2_in##S(T x) {                                                                       \
    const T t = x + (T)(12582912.0f);                                                               \
    const T f = x - (t - (T)(12582912.0f));                                                         \
    T p = fma(f, (T)(0.0013276472f), (T)(0.009675541f));                                            \
    p = fma(p, f, (T)(0.055507131f));                                                               \
    p = fma(p, f, (T)(0.2402212f));                                                                 \
    p = fma(p, f, (T)(0.69314694f));                                                                \
    p = fma(p, f, (T)(1.0000001f));                                                                 \
    return as_##T(as_##TI(p) + ((as_##TI(t) - 0x4B400000) << 23));                                 \
  }                                                                                                 \
  T bsdfmix_exp2##S(T x) { return bsdfmix_exp2_in##S(fmin(fmax(x, (T)(-125.0f)), (T)(127.0f))); }
BSDFMIX_EXP2(float, int, )
BSDFMIX_EXP2(float4, int4, 4)
BSDFMIX_EXP2(float8, int8, 8)
BSDFMIX_EXP2(float16, int16, 16)
