// mis_product's per-vertex product: carried lighting, pairs, pruning, sampling, density.
#include "render/fast_product.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>

#include "render/light_carry.hpp"

namespace bsdfmix {
namespace render {

namespace {

constexpr float kTwoPiF = float(2 * kPi), kPiF = float(kPi);

// exp(x) for x <= 0 in float, branch-free so that loops over it vectorize (the C
// library's expf does not without -ffast-math): x = n ln 2 + r, |r| <= ln 2 / 2, e^r by
// Cephes' polynomial (relative error about 1e-7), 2^n from the exponent bits; 0 below -85.
inline float exp_nonpositive(float x) {
  const float xc = x < -86.f ? -86.f : x;
  const int n = int(xc * 1.44269504088896341f - 0.5f);  // round to nearest for negative arguments
  const float fn = float(n);
  const float r = (xc - fn * 0.693359375f) + fn * 2.12194440e-4f;
  float p = 1.9875691500e-4f;
  p = p * r + 1.3981999507e-3f;
  p = p * r + 8.3334519073e-3f;
  p = p * r + 4.1665795894e-2f;
  p = p * r + 1.6666665459e-1f;
  p = p * r + 5.0000001201e-1f;
  const float er = p * r * r + r + 1.f;
  const std::int32_t bits = (n + 127) << 23;
  float two_n;
  std::memcpy(&two_n, &bits, sizeof two_n);
  return x < -85.f ? 0.f : er * two_n;
}

constexpr int kBuckets = 32;

// wrap_phi without fmod: [-pi, pi) for the few periods a product's angles span
inline double wrap(double phi) {
  const double r = phi - 2 * kPi * std::floor((phi + kPi) / (2 * kPi));
  return r >= kPi ? r - 2 * kPi : (r < -kPi ? r + 2 * kPi : r);
}

// phi differences of two wrapped angles (in (-2 pi, 2 pi)) to the nearest image, [-pi, pi]
inline float nearest_image(float d) {
  d = d > kPiF ? d - kTwoPiF : d;
  return d < -kPiF ? d + kTwoPiF : d;
}

// One lighting component's pair weights with every bsdf component, at the nearest phi
// image (out0) and the two next to it (out1: 2 pi below, out2: above): restrict pointers,
// one loop the compiler vectorizes.
void pair_weights(const ProductFactor& a, std::size_t nb, float lt, float lp, float tt, float tp, float pp, float lw,
                  float* __restrict out0, float* __restrict out1, float* __restrict out2) {
  const float* __restrict aw = a.w.data();
  const float* __restrict amt = a.mt.data();
  const float* __restrict amp = a.mp.data();
  const float* __restrict att = a.stt.data();
  const float* __restrict atp = a.stp.data();
  const float* __restrict app = a.spp.data();
  const float inv_2pi = float(1 / (2 * kPi));
  for (std::size_t i = 0; i < nb; ++i) {
    const float st = att[i] + tt, sp = app[i] + pp, sx = atp[i] + tp;
    const float det = st * sp - sx * sx;
    const float ok = det > 0.f ? 1.f : 0.f;
    const float idet = 1.f / (det > 0.f ? det : 1.f);
    const float dt = amt[i] - lt, dp = nearest_image(amp[i] - lp);
    const float base = sp * dt * dt, cross = 2.f * sx * dt;
    const float c = ok * aw[i] * lw * inv_2pi / std::sqrt(det > 0.f ? det : 1.f);
    const float d1 = dp - kTwoPiF, d2 = dp + kTwoPiF;
    out0[i] = c * exp_nonpositive(-0.5f * (base - cross * dp + st * dp * dp) * idet);
    out1[i] = c * exp_nonpositive(-0.5f * (base - cross * d1 + st * d1 * d1) * idet);
    out2[i] = c * exp_nonpositive(-0.5f * (base - cross * d2 + st * d2 * d2) * idet);
  }
}

}  // namespace

void ProductFactor::assign(const mix::SliceMixture& s) {
  for (auto* v : {&w, &mt, &mp, &stt, &stp, &spp, &itt, &itp, &ipp}) v->clear();
  map = s.map;
  for (const mix::Gaussian& g : mix::product_parts(s)) {  // a base as the header's product takes it
    w.push_back(float(g.weight));
    mt.push_back(float(g.mu_t));
    mp.push_back(float(wrap_phi(g.mu_p)));
    stt.push_back(float(g.s_tt));
    stp.push_back(float(g.s_tp));
    spp.push_back(float(g.s_pp));
    itt.push_back(float(g.i_tt));
    itp.push_back(float(g.i_tp));
    ipp.push_back(float(g.i_pp));
  }
}

CarrySource::CarrySource(const std::vector<mix::Gaussian>& compact, const LocalAxes& from) {
  for (const mix::Gaussian& g : compact) {
    const double ct = std::cos(g.mu_t), st = std::sin(g.mu_t), cp = std::cos(g.mu_p), sp = std::sin(g.mu_p);
    Lobe l;
    for (std::size_t i = 0; i < 3; ++i) {
      l.w[i] = ct * cp * from.e1[i] + ct * sp * from.e2[i] + st * from.axis[i];
      l.dwt[i] = -st * cp * from.e1[i] - st * sp * from.e2[i] + ct * from.axis[i];
      l.dwp[i] = -ct * sp * from.e1[i] + ct * cp * from.e2[i];
    }
    l.s_tt = g.s_tt;
    l.s_tp = g.s_tp;
    l.s_pp = g.s_pp;
    l.weight = g.weight;
    l.sigma_max = g.sigma_max();
    lobes.push_back(l);
  }
}

bool FastProduct::build(const ProductFactor& a, const CarrySource& src, const LocalAxes& f,
                        const mix::ProductOptions& o) {
  for (auto* v : {&lw_, &lmt_, &lmp_, &ltt_, &ltp_, &lpp_, &litt_, &litp_, &lipp_, &w_, &wn_, &mt_, &mp_, &itt_, &ipp_, &ctt_, &cpt_, &cpp_, &cdf_, &wide_cut_})
    v->clear();
  wide_.clear();
  map_ = a.map;
  carry_lighting(src, f);
  const std::size_t nb = a.size(), nl = lw_.size(), nc = 3 * nb * nl;
  if (nb == 0 || nl == 0) return false;
  // 2. Every pair's weight w_i w_j N(m_i; m_j, S_i + S_j) at the three nearest phi
  // images, over the bsdf's components in one loop the compiler vectorizes.
  cand_.resize(nc);
  for (std::size_t j = 0; j < nl; ++j) {
    const float lt = lmt_[j], lp = lmp_[j], tt = ltt_[j], tp = ltp_[j], pp = lpp_[j], lw = lw_[j];
    float *out0 = &cand_[nb * j], *out1 = out0 + nb * nl, *out2 = out1 + nb * nl;
    pair_weights(a, nb, lt, lp, tt, tp, pp, lw, out0, out1, out2);
  }
  double total = 0;
  for (float c : cand_) total += double(c);
  if (!(total > 0) || !std::isfinite(total)) return false;  // no overlap, or a degenerate pair: light sampling alone
  const std::size_t top = keep_heaviest(total, o);
  const double acc = add_pairs(a, top);
  if (w_.empty()) return false;
  term_.resize(w_.size());
  normalize(acc);
  return true;
}

// 1. The lighting in the frame: carry_lighting's map, from the precomputed directions,
// then on into the plane of map_ (compose_map_jacobian) as carry_lighting does.
// The lighting is a function L over the plane, not a density: a lobe keeps its value at
// each direction when its weight is multiplied by |det| of the Jacobian from its plane to
// the new one (its 1 / (2 pi sqrt(det S)) shrinks by that factor). The frame change gives
// cos(theta_w) / rho; the map multiplies it by |det M| = map_jacobian (cos theta on the
// cylinder, sin theta on the disk). Times the BSDF factor (per unit of the plane) it is the
// integrand f cos L per unit of the plane, as on (theta, phi).
void FastProduct::carry_lighting(const CarrySource& src, const LocalAxes& f) {
  const bool fiber = f.domain == Domain::Fiber;
  const double sgn = fiber ? 1.0 : -1.0, cap = 4 * kPi * kPi;
  for (const CarrySource::Lobe& g : src.lobes) {
    const double z = std::clamp(dot(g.w, f.axis), -1.0, 1.0), x = dot(g.w, f.e1), y = dot(g.w, f.e2);
    const double rho2 = x * x + y * y;
    if (!(rho2 > 1e-12)) continue;  // on the pole itself: left to light sampling
    const double mu_t = fiber ? std::asin(z) : std::acos(z);
    if (!fiber && mu_t > kPi / 2 + 4 * g.sigma_max) continue;  // below the horizon: lights nothing here
    const double rho = std::sqrt(rho2);
    double j11 = sgn * dot(g.dwt, f.axis) / rho, j12 = sgn * dot(g.dwp, f.axis) / rho;
    double j21 = (x * dot(g.dwt, f.e2) - y * dot(g.dwt, f.e1)) / rho2;
    double j22 = (x * dot(g.dwp, f.e2) - y * dot(g.dwp, f.e1)) / rho2;
    double mx = mu_t, my = std::atan2(y, x), s_theta = 0;
    if (map_ != mix::Map::ThetaPhi) {
      s_theta = j11 * j11 * g.s_tt + 2 * j11 * j12 * g.s_tp + j12 * j12 * g.s_pp;
      double j[4] = {j11, j12, j21, j22};
      compose_map_jacobian(map_, mu_t, x / rho, y / rho, j);
      j11 = j[0], j12 = j[1], j21 = j[2], j22 = j[3];
      mix::to_map(map_, mu_t, my, mx, my);
    }
    double s_tt = j11 * j11 * g.s_tt + 2 * j11 * j12 * g.s_tp + j12 * j12 * g.s_pp;
    if (map_ == mix::Map::Cylinder) s_tt += map_curvature_variance(map_, mu_t, s_theta);
    double s_tp = j11 * j21 * g.s_tt + (j11 * j22 + j12 * j21) * g.s_tp + j12 * j22 * g.s_pp;
    double s_pp = j21 * j21 * g.s_tt + 2 * j21 * j22 * g.s_tp + j22 * j22 * g.s_pp;
    const double weight = g.weight * std::abs(j11 * j22 - j12 * j21);
    if (map_ != mix::Map::Disk && s_pp > cap) {  // uniform in phi: keep the correlation coefficient
      s_tp *= std::sqrt(cap / s_pp);
      s_pp = cap;
    }
    double det = s_tt * s_pp - s_tp * s_tp;
    if (!(det > 1e-9 * s_tt * s_pp)) {
      s_tp = std::copysign(std::sqrt((1 - 1e-9) * s_tt * s_pp), s_tp);
      det = s_tt * s_pp - s_tp * s_tp;
    }
    if (!(weight > 0 && std::isfinite(weight) && s_tt > 0 && det > 0)) continue;
    lw_.push_back(float(weight));
    lmt_.push_back(float(mx));
    lmp_.push_back(float(my));
    ltt_.push_back(float(s_tt));
    ltp_.push_back(float(s_tp));
    lpp_.push_back(float(s_pp));
    litt_.push_back(float(s_pp / det));
    litp_.push_back(float(-s_tp / det));
    lipp_.push_back(float(s_tt / det));
  }
}

// 3. The pairs kept: the heaviest, all but at most 1 - keep of the mass, found without
// sorting. Each candidate falls into a bucket by its float exponent below the heaviest
// (a factor 2 per bucket); whole buckets are dropped from the lightest up while what
// they hold together stays within 1 - keep of the total. This keeps the header's pairs
// (heaviest first to `keep`) and at most those within a factor 2 of its lightest; more
// than max_components are cut to the heaviest by a selection.
std::size_t FastProduct::keep_heaviest(double total, const mix::ProductOptions& o) {
  const std::size_t nc = cand_.size();
  float wmax = 0;
  for (float c : cand_) wmax = std::max(wmax, c);
  double bucket[kBuckets] = {};
  const auto level = [wmax](float c) {
    std::int32_t bm, bc;
    std::memcpy(&bm, &wmax, sizeof bm);
    std::memcpy(&bc, &c, sizeof bc);
    return std::min((bm >> 23) - (bc >> 23), kBuckets - 1);
  };
  for (float c : cand_)
    if (c > 0.f) bucket[level(c)] += double(c);
  const double drop = std::max(0.0, 1 - o.keep) * total;
  int cut = kBuckets;  // candidates at level >= cut are dropped
  for (double dropped = 0; cut > 1 && dropped + bucket[cut - 1] <= drop; --cut) dropped += bucket[cut - 1];
  order_.clear();
  for (std::size_t k = 0; k < nc; ++k)
    if (cand_[k] > 0.f && level(cand_[k]) < cut) order_.push_back({cand_[k], int(k)});
  const std::size_t max_k = std::max<std::size_t>(o.max_components, 1);
  if (order_.size() > max_k)
    std::nth_element(order_.begin(), order_.begin() + std::ptrdiff_t(max_k - 1), order_.end(),
                     [](const std::pair<float, int>& p, const std::pair<float, int>& q) {
                       return p.first > q.first || (p.first == q.first && p.second < q.second);
                     });
  return std::min(order_.size(), max_k);
}

// 4. The kept pairs' Gaussians: precision P = P_i + P_j, mean P^-1 (P_i m_i + P_j m_j),
// and the Cholesky factor of P^-1 that both the sampler and the density use; the sum of
// their weights.
double FastProduct::add_pairs(const ProductFactor& a, std::size_t top) {
  const std::size_t nb = a.size(), nl = lw_.size();
  double acc = 0;
  for (std::size_t r = 0; r < top; ++r) {
    const int idx = order_[r].second;
    const std::size_t k = std::size_t(idx) / (nb * nl), j = (std::size_t(idx) / nb) % nl, i = std::size_t(idx) % nb;
    const double ptt = double(a.itt[i]) + litt_[j], ptp = double(a.itp[i]) + litp_[j], ppp = double(a.ipp[i]) + lipp_[j];
    const double pdet = ptt * ppp - ptp * ptp;
    if (!(pdet > 0)) continue;
    const double s_tt = ppp / pdet, s_tp = -ptp / pdet, s_pp = ptt / pdet;
    const double dp = double(nearest_image(a.mp[i] - lmp_[j])) + (k == 1 ? -2 * kPi : k == 2 ? 2 * kPi : 0.0);
    const double at = a.mt[i], ap = double(lmp_[j]) + dp;
    const double ht = a.itt[i] * at + a.itp[i] * ap + double(litt_[j]) * lmt_[j] + double(litp_[j]) * lmp_[j];
    const double hp = a.itp[i] * at + a.ipp[i] * ap + double(litp_[j]) * lmt_[j] + double(lipp_[j]) * lmp_[j];
    const double l_tt = std::sqrt(s_tt), l_pt = s_tp / l_tt, l_pp = std::sqrt(std::max(s_pp - l_pt * l_pt, 0.0));
    const float ftt = float(l_tt), fpt = float(l_pt), fpp = float(l_pp);
    if (!(ftt > 0.f) || !(fpp > 0.f) || !std::isfinite(ftt) || !std::isfinite(fpt) || !std::isfinite(fpp)) continue;
    if (!std::isfinite(1.f / ftt * (1.f / fpp))) continue;  // a density beyond float's range
    acc += double(order_[r].first);
    w_.push_back(order_[r].first);
    mt_.push_back(float(s_tt * ht + s_tp * hp));
    mp_.push_back(float(wrap(s_tp * ht + s_pp * hp)));
    ctt_.push_back(ftt);
    cpt_.push_back(fpt);
    cpp_.push_back(fpp);
    itt_.push_back(1.f / ftt);  // the inverse factor's diagonal: z0 = dt / l_tt, z1 = (dp - l_pt z0) / l_pp
    ipp_.push_back(1.f / fpp);
  }
  return acc;
}

// 5. Normalized weights, the CDF, each component's weight over its 2 pi det(L), and the
// components whose phi spread reaches images beyond the nearest three (9 sigma >= 3 pi).
void FastProduct::normalize(double acc) {
  float run = 0;
  const double dinv = 1 / acc;
  const float inv = float(dinv), inv_2pi = float(1 / (2 * kPi));
  // pairs that barely overlap can sum to less than 1 / FLT_MAX: then the division in double
  const bool wide_inv = !std::isfinite(inv);
  wn_.resize(w_.size());
  for (std::size_t c = 0; c < w_.size(); ++c) {
    w_[c] = wide_inv ? float(double(w_[c]) * dinv) : w_[c] * inv;
    run += w_[c];
    cdf_.push_back(run);
    wn_[c] = w_[c] * inv_2pi * itt_[c] * ipp_[c];
    const float sigma_p = std::sqrt(cpt_[c] * cpt_[c] + cpp_[c] * cpp_[c]);
    if (9.f * sigma_p >= 3.f * kPiF) {
      wide_.push_back(int(c));
      wide_cut_.push_back(9.f * sigma_p);
    }
  }
  cdf_.back() = 1.f;
}

mix::Sample FastProduct::sample(Domain d, double u1, double u2, double u3) const {
  mix::Sample out;
  if (w_.empty()) return out;
  std::size_t c = std::size_t(std::upper_bound(cdf_.begin(), cdf_.end(), float(u1)) - cdf_.begin());
  c = std::min(c, w_.size() - 1);
  double z0, z1;
  mix::normal_pair(u2, u3, z0, z1);
  if (map_ != mix::Map::ThetaPhi) {  // a point of the plane, taken to its direction
    const double x = double(mt_[c]) + double(ctt_[c]) * z0;
    const double y = wrap(double(mp_[c]) + double(cpt_[c]) * z0 + double(cpp_[c]) * z1);
    out.valid = mix::from_map(map_, x, y, out.theta, out.phi);
    out.pdf_omega = out.valid ? pdf_plane(float(x), float(y)) : 0.0;
    if (!(out.pdf_omega > 0)) out.valid = false;
    return out;
  }
  out.theta = double(mt_[c]) + double(ctt_[c]) * z0;
  out.phi = wrap(double(mp_[c]) + double(cpt_[c]) * z0 + double(cpp_[c]) * z1);
  out.valid = out.theta >= mix::theta_lo(d) && out.theta <= mix::theta_hi(d);
  out.pdf_omega = out.valid ? pdf_omega(d, out.theta, out.phi) : 0.0;
  if (!(out.pdf_omega > 0)) out.valid = false;
  return out;
}

double FastProduct::pdf_omega(Domain d, double theta, double phi) const {
  if (theta < mix::theta_lo(d) || theta > mix::theta_hi(d)) return 0;
  if (map_ != mix::Map::ThetaPhi) {  // equal-area: per unit of the plane is per steradian
    double x, y;
    mix::to_map(map_, theta, phi, x, y);
    return pdf_plane(float(x), float(wrap(y)));
  }
  const double jac = mix::jacobian(d, theta);
  if (!(jac > 0)) return 0;
  return pdf_plane(float(theta), float(wrap(phi))) / jac;
}

double FastProduct::pdf_plane(float th, float ph) const {
  const std::size_t n = w_.size();
  const float *wn = wn_.data(), *mt = mt_.data(), *mp = mp_.data(), *it = itt_.data(), *ip = ipp_.data(),
              *cpt = cpt_.data();
  float* term = term_.data();
  for (std::size_t c = 0; c < n; ++c) {  // vectorized; the sum after it (a float reduction would not be)
    const float z0 = (th - mt[c]) * it[c], dp = nearest_image(ph - mp[c]);
    const float a = (dp - cpt[c] * z0) * ip[c], b = (dp - kTwoPiF - cpt[c] * z0) * ip[c],
                e = (dp + kTwoPiF - cpt[c] * z0) * ip[c];
    const float q0 = z0 * z0;
    term[c] = wn[c] * (exp_nonpositive(-0.5f * (q0 + a * a)) + exp_nonpositive(-0.5f * (q0 + b * b)) +
                       exp_nonpositive(-0.5f * (q0 + e * e)));
  }
  float sum = 0;
  for (std::size_t c = 0; c < n; ++c) sum += term[c];
  // the wide components' farther images, out to 9 sigma as the header's density
  double extra = 0;
  for (std::size_t k = 0; k < wide_.size(); ++k) {
    const std::size_t c = std::size_t(wide_[k]);
    const double z0 = (double(th) - mt_[c]) * itt_[c], dp = nearest_image(ph - mp_[c]);
    for (int m = 2;; ++m) {
      bool any = false;
      for (const double s : {-1.0, 1.0}) {
        const double x = dp + s * 2 * kPi * m;
        if (std::abs(x) > wide_cut_[k]) continue;
        any = true;
        const double z1 = (x - cpt_[c] * z0) * ipp_[c];
        extra += wn_[c] * std::exp(-0.5 * (z0 * z0 + z1 * z1));
      }
      if (!any) break;
    }
  }
  return double(sum) + extra;
}

mix::SliceMixture FastProduct::mixture() const {
  mix::SliceMixture m;
  m.scale = 1;
  m.map = map_;
  for (std::size_t c = 0; c < w_.size(); ++c) {
    mix::Gaussian g;
    g.weight = w_[c];
    g.mu_t = mt_[c];
    g.mu_p = mp_[c];
    g.s_tt = double(ctt_[c]) * ctt_[c];
    g.s_tp = double(ctt_[c]) * cpt_[c];
    g.s_pp = double(cpt_[c]) * cpt_[c] + double(cpp_[c]) * cpp_[c];
    m.components.push_back(g);
  }
  if (!m.components.empty()) m.prepare();
  return m;
}

}  // namespace render
}  // namespace bsdfmix
