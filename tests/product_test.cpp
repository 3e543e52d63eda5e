// Product sampling of the renderer-facing header include/bsdfmix/mixture.hpp (product(),
// MixtureSet::blended, MixtureSet::product_with): the product of two Gaussians against
// its closed form, the product across phi = +-pi and with a rotation, the pointwise
// identity pdf * mass = a * b for mixtures with broad phi lobes, Pearson chi-square of
// product samples (pruned and unpruned, a lobe cut by the theta border, both domains),
// the pdf integrating to the analytic mass inside the theta range, pruning (`kept`), and a
// Lambertian base on the disk as its fit of the cosine dome.
// labels: sample
#include <catch2/catch.hpp>

#include "chi_square.hpp"
#include "gaussians.hpp"

#include <bsdfmix/mixture.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <vector>

using namespace bsdfmix::mix;

namespace {

using bsdfmix::test::gaussian;

// Fixed seed (printed); PRODUCT_TEST_SEED overrides it to re-check with other streams.
const std::uint64_t kSeed = std::getenv("PRODUCT_TEST_SEED")
                                ? std::strtoull(std::getenv("PRODUCT_TEST_SEED"), nullptr, 10)
                                : 20240611ull;


SliceMixture mixture(std::vector<Gaussian> comps) {
  SliceMixture m;
  m.components = std::move(comps);
  m.prepare();
  return m;
}

// Symmetric 2x2 [a b; b c] and 2-vectors, written out independently of the header.
struct Sym {
  double a, b, c;
};
struct V2 {
  double t, p;
};
Sym cov(const Gaussian& g) { return {g.s_tt, g.s_tp, g.s_pp}; }
double det(const Sym& s) { return s.a * s.c - s.b * s.b; }
Sym inv(const Sym& s) {
  const double d = det(s);
  return {s.c / d, -s.b / d, s.a / d};
}
Sym add(const Sym& x, const Sym& y) { return {x.a + y.a, x.b + y.b, x.c + y.c}; }
V2 mul(const Sym& s, const V2& v) { return {s.a * v.t + s.b * v.p, s.b * v.t + s.c * v.p}; }
// N(x; m, S) in 2D
double normal(const V2& x, const V2& m, const Sym& s) {
  const V2 d{x.t - m.t, x.p - m.p};
  const V2 id = mul(inv(s), d);
  return std::exp(-0.5 * (d.t * id.t + d.p * id.p)) / (2 * kPi * std::sqrt(det(s)));
}

// The closed-form product of two Gaussians: covariance, mean and the scale factor c.
struct Closed {
  Sym s;
  V2 m;
  double c;
};
Closed closed_product(const V2& ma, const Sym& sa, const V2& mb, const Sym& sb) {
  Closed r;
  const Sym ia = inv(sa), ib = inv(sb);
  r.s = inv(add(ia, ib));
  const V2 ha = mul(ia, ma), hb = mul(ib, mb);
  r.m = mul(r.s, {ha.t + hb.t, ha.p + hb.p});
  r.c = normal(ma, mb, add(sa, sb));
  return r;
}

double rel(double x, double ref) { return std::abs(x - ref) / std::max(std::abs(ref), 1e-300); }

// Standard normal CDF.
double Phi(double x) { return 0.5 * std::erfc(-x / std::sqrt(2.0)); }

const double kGx[6] = {-0.9324695142031521, -0.6612093864662645, -0.2386191860831969,
                       0.2386191860831969,  0.6612093864662645,  0.9324695142031521};
const double kGw[6] = {0.1713244923791704, 0.3607615730481386, 0.4679139345726910,
                       0.4679139345726910, 0.3607615730481386, 0.1713244923791704};

// Integral over [t0, t1] x [p0, p1] of pdf_omega * J (the density per dtheta dphi of
// what sample() returns), Gauss-Legendre 6 x 6.
double bin_mass(const SliceMixture& m, Domain d, double t0, double t1, double p0, double p1) {
  double s = 0;
  for (int i = 0; i < 6; ++i)
    for (int j = 0; j < 6; ++j) {
      const double t = 0.5 * (t0 + t1) + 0.5 * (t1 - t0) * kGx[i], p = 0.5 * (p0 + p1) + 0.5 * (p1 - p0) * kGx[j];
      s += kGw[i] * kGw[j] * m.pdf_omega(d, t, p) * jacobian(d, t);
    }
  return s * 0.25 * (t1 - t0) * (p1 - p0);
}

struct Chi2 {
  double stat = 0, p = 0, mass = 0, invalid = 0;
  int dof = 0;
};

// Pearson chi-square of `n` samples of m.sample(d, u1, u2, u3) (Philox uniforms of
// `stream`) against the pdf on a 20 x 40 theta x phi histogram plus one "invalid" bin;
// bins expecting fewer than 5 samples are pooled.
Chi2 chi2(const SliceMixture& m, Domain d, std::uint32_t stream, std::size_t n) {
  const int nt = 20, np = 40;
  const double lo = theta_lo(d), hi = theta_hi(d);
  std::vector<double> obs(std::size_t(nt * np + 1), 0.0), expct(obs.size(), 0.0);
  for (std::size_t k = 0; k < n; ++k) {
    double u[4];
    uniforms(kSeed, stream, k, u);
    const Sample x = m.sample(d, u[1], u[2], u[3]);
    if (!x.valid) {
      obs.back() += 1;
      continue;
    }
    const int i = std::clamp(int((x.theta - lo) / (hi - lo) * nt), 0, nt - 1);
    const int j = std::clamp(int((x.phi + kPi) / (2 * kPi) * np), 0, np - 1);
    obs[std::size_t(i * np + j)] += 1;
  }
  Chi2 r;
  const double N = double(n);
  for (int i = 0; i < nt; ++i)
    for (int j = 0; j < np; ++j) {
      const double mm = bin_mass(m, d, lo + (hi - lo) * i / nt, lo + (hi - lo) * (i + 1) / nt,
                                 -kPi + 2 * kPi * j / np, -kPi + 2 * kPi * (j + 1) / np);
      r.mass += mm;
      expct[std::size_t(i * np + j)] = mm * N;
    }
  expct.back() = std::max(0.0, 1 - r.mass) * N;
  r.invalid = obs.back() / N;
  const bsdfmix::test::ChiSquare c = bsdfmix::test::pearson(obs, expct);
  r.stat = c.stat;
  r.p = c.p;
  r.dof = c.dof;
  return r;
}

// Chi-square check, printed; returns the invalid fraction.
double check_chi2(const SliceMixture& m, Domain d, std::uint32_t stream, const char* what) {
  const std::size_t n = 200000;
  const Chi2 c = chi2(m, d, stream, n);
  std::printf("product_test: chi2 %s (%zu components): seed %llu, chi2 %.1f, dof %d, p-value %.4f, pdf mass %.6f, "
              "1 - invalid %.6f\n",
              what, m.components.size(), (unsigned long long)kSeed, c.stat, c.dof, c.p, c.mass, 1 - c.invalid);
  INFO(what << ": chi2 " << c.stat << " with " << c.dof << " dof, p-value " << c.p << ", mass " << c.mass
            << ", invalid " << c.invalid);
  CHECK(c.p > 0.01);
  const double se = std::sqrt(std::max(c.invalid * (1 - c.invalid), 1e-12) / double(n));
  CHECK(std::abs(c.mass - (1 - c.invalid)) < 4 * se + 2e-4);
  return c.invalid;
}

// Worst relative error of product.pdf_param * mass against a(theta, phi - rotate) *
// b(theta, phi) at the points, over values above 1e-12 of their max; `relative_to_max`
// measures the error relative to the max instead of the point's value.
double worst_identity(const SliceMixture& prod, double mass, const SliceMixture& a, double rotate,
                      const SliceMixture& b, const std::vector<double>& thetas, const std::vector<double>& phis,
                      bool relative_to_max, std::size_t* checked = nullptr) {
  std::vector<double> ref, got;
  double vmax = 0;
  for (const double t : thetas)
    for (const double p : phis) {
      ref.push_back(a.pdf_param(t, wrap_phi(p - rotate)) * b.pdf_param(t, p));
      got.push_back(prod.pdf_param(t, p) * mass);
      vmax = std::max(vmax, ref.back());
    }
  double worst = 0;
  std::size_t count = 0;
  for (std::size_t k = 0; k < ref.size(); ++k) {
    if (relative_to_max) {
      worst = std::max(worst, std::abs(got[k] - ref[k]) / vmax);
      ++count;
    } else if (ref[k] > 1e-12 * vmax) {
      worst = std::max(worst, rel(got[k], ref[k]));
      ++count;
    }
  }
  if (checked) *checked = count;
  return worst;
}

// Analytic mass of a prepared mixture inside theta in [lo, hi] (phi over one period).
double analytic_mass(const SliceMixture& m, double lo, double hi) {
  double s = 0;
  for (const Gaussian& g : m.components) {
    const double sd = std::sqrt(g.s_tt);
    s += g.weight * (Phi((hi - g.mu_t) / sd) - Phi((lo - g.mu_t) / sd));
  }
  return s;
}

// Quadrature of pdf_param over theta in [lo, hi] (64 Gauss-Legendre panels of 6 nodes)
// and one phi period (periodic trapezoid, 512 points).
double quadrature_mass(const SliceMixture& m, double lo, double hi) {
  const int panels = 64, nphi = 512;
  double s = 0;
  for (int k = 0; k < panels; ++k) {
    const double t0 = lo + (hi - lo) * k / panels, t1 = lo + (hi - lo) * (k + 1) / panels;
    for (int i = 0; i < 6; ++i) {
      const double t = 0.5 * (t0 + t1) + 0.5 * (t1 - t0) * kGx[i];
      double row = 0;
      for (int j = 0; j < nphi; ++j) row += m.pdf_param(t, -kPi + 2 * kPi * j / nphi);
      s += kGw[i] * 0.5 * (t1 - t0) * row * 2 * kPi / nphi;
    }
  }
  return s;
}

// Two mixtures with broad phi lobes (sigma_phi 1.5) and a lobe across the seam.
SliceMixture broad_a() {
  return mixture({gaussian(0.35, 0.3, 0.5, 0.25, 1.5, 0.4), gaussian(0.25, -0.6, 2.9, 0.2, 0.35, -0.3),
                  gaussian(0.25, 0.9, -1.8, 0.3, 0.8, 0.2), gaussian(0.15, -0.2, -3.0, 0.4, 1.6, -0.5)});
}
SliceMixture broad_b() {
  return mixture({gaussian(0.5, 0.1, -2.5, 0.35, 1.5, 0.3), gaussian(0.3, -0.5, 3.0, 0.3, 0.4, 0.1),
                  gaussian(0.2, 0.7, 0.8, 0.25, 1.2, -0.6)});
}

}  // namespace

TEST_CASE("product of two correlated Gaussians equals the closed form", "[sample][product]") {
  const Gaussian ga = gaussian(1.0, 0.3, 0.4, 0.2, 0.35, 0.5), gb = gaussian(1.0, -0.1, -0.2, 0.25, 0.3, -0.4);
  const SliceMixture a = mixture({ga}), b = mixture({gb});
  double mass = 0, kept = 0;
  const SliceMixture p = product(a, 0.0, b, ProductOptions{1.0, 1000}, &mass, &kept);
  REQUIRE(p.components.size() == 1);
  const Closed cf = closed_product({ga.mu_t, ga.mu_p}, cov(ga), {gb.mu_t, gb.mu_p}, cov(gb));
  const Gaussian& g = p.components[0];
  const double errs[7] = {rel(g.s_tt, cf.s.a), rel(g.s_tp, cf.s.b), rel(g.s_pp, cf.s.c), rel(g.mu_t, cf.m.t),
                          rel(g.mu_p, cf.m.p), rel(mass, cf.c),      rel(g.weight, 1.0)};
  const double worst = *std::max_element(errs, errs + 7);
  std::printf("product_test: closed form (2 Gaussians, rho 0.5 / -0.4): mass %.15g vs %.15g, worst rel error %.2e "
              "over S, mu, mass\n",
              mass, cf.c, worst);
  for (int k = 0; k < 7; ++k) {
    INFO("quantity " << k << " relative error " << errs[k]);
    CHECK(errs[k] < 1e-12);
  }
  CHECK(std::abs(kept - 1) < 1e-12);
  CHECK(p.scale == mass);
}

TEST_CASE("product across the phi seam and with a rotation of a: pdf * mass = a * b pointwise", "[sample][product]") {
  const Gaussian ga = gaussian(1.0, 0.2, 3.0, 0.15, 0.2, 0.3), gb = gaussian(1.0, 0.35, -3.0, 0.2, 0.25, -0.2);
  const SliceMixture a = mixture({ga}), b = mixture({gb});
  const ProductOptions all{1.0, 1000};
  std::vector<double> thetas, phis;
  for (int i = 0; i <= 40; ++i) thetas.push_back(-kPi / 2 + kPi * i / 40);
  for (int j = 0; j < 360; ++j) phis.push_back(-kPi + 2 * kPi * (j + 0.3) / 360);
  for (const double p : {-kPi, -kPi + 1e-9, -kPi + 1e-4, -3.1, -3.0, 3.0, 3.1, kPi - 1e-4, kPi - 1e-9})
    phis.push_back(p);

  {  // the seam: the dominant component sits near +-pi, the closed form with b unwrapped
    double mass = 0, kept = 0;
    const SliceMixture p = product(a, 0.0, b, all, &mass, &kept);
    REQUIRE(!p.components.empty());
    const Gaussian& g = p.components[0];  // heaviest first
    const Closed cf = closed_product({ga.mu_t, ga.mu_p}, cov(ga), {gb.mu_t, gb.mu_p + 2 * kPi}, cov(gb));
    const double dmu = std::max(std::abs(g.mu_t - cf.m.t), std::abs(wrap_phi(g.mu_p - cf.m.p)));
    std::printf("product_test: seam product: %zu component(s), top weight %.15f, mean (%.6f, %.6f) vs closed form "
                "(%.6f, %.6f wrapped %.6f), mass %.12g vs %.12g\n",
                p.components.size(), g.weight, g.mu_t, g.mu_p, cf.m.t, cf.m.p, wrap_phi(cf.m.p), mass, cf.c);
    CHECK(g.weight > 1 - 1e-12);
    CHECK(std::abs(g.mu_p) > 2.9);  // near +-pi
    CHECK(g.mu_p >= -kPi);
    CHECK(g.mu_p < kPi);
    CHECK(dmu < 1e-12);
    CHECK(rel(g.s_tt, cf.s.a) < 1e-12);
    CHECK(rel(g.s_tp, cf.s.b) < 1e-12);
    CHECK(rel(g.s_pp, cf.s.c) < 1e-12);
    CHECK(rel(mass, cf.c) < 1e-12);
    std::size_t checked = 0;
    const double worst = worst_identity(p, mass, a, 0.0, b, thetas, phis, false, &checked);
    std::printf("product_test: seam identity pdf*mass = a*b: %zu points above 1e-12 of max, worst rel error %.2e\n",
                checked, worst);
    CHECK(worst < 1e-9);
    CHECK(checked > 100);
  }
  for (const double rot : {0.7, -6.5, -2 * kPi + 0.25, 2 * kPi - 0.1}) {  // a's mean near b's, some across the seam
    double mass = 0, kept = 0;
    const SliceMixture p = product(a, rot, b, all, &mass, &kept);
    std::size_t checked = 0;
    const double worst = worst_identity(p, mass, a, rot, b, thetas, phis, false, &checked);
    // a rotated by rot against the closed form (a's mean shifted, wrapped nearest b's)
    const double shifted = gb.mu_p + wrap_phi(ga.mu_p + rot - gb.mu_p);
    const Closed cf = closed_product({ga.mu_t, shifted}, cov(ga), {gb.mu_t, gb.mu_p}, cov(gb));
    std::printf("product_test: rotate_a %.4f: %zu component(s), mass %.12g vs %.12g, identity on %zu points, worst rel "
                "error %.2e\n",
                rot, p.components.size(), mass, cf.c, checked, worst);
    INFO("rotate_a " << rot);
    CHECK(worst < 1e-9);
    CHECK(checked > 100);
    CHECK(mass > 0.1);  // the two overlap (else only 9-sigma tails meet)
    CHECK(rel(mass, cf.c) < 1e-12);
    CHECK(std::abs(wrap_phi(p.components[0].mu_p - cf.m.p)) < 1e-12);
  }
}

TEST_CASE("mixture product with broad phi lobes: pdf * mass = a * b on a 120 x 240 grid", "[sample][product]") {
  const SliceMixture a = broad_a(), b = broad_b();
  std::vector<double> thetas, phis;
  for (int i = 0; i < 120; ++i) thetas.push_back(-kPi / 2 + kPi * (i + 0.5) / 120);
  for (int j = 0; j < 240; ++j) phis.push_back(-kPi + 2 * kPi * j / 240);
  for (const double rot : {0.0, 1.3, -3.0}) {
    double mass = 0, kept = 0;
    const SliceMixture p = product(a, rot, b, ProductOptions{1.0, 1000}, &mass, &kept);
    const double worst = worst_identity(p, mass, a, rot, b, thetas, phis, true);
    std::printf("product_test: broad mixtures (4 x 3), rotate_a %.2f: %zu product components (phi images), kept %.3f, "
                "worst error %.2e of the max\n",
                rot, p.components.size(), kept, worst);
    INFO("rotate_a " << rot);
    CHECK(p.components.size() > 12);  // more than one phi image of some pair
    CHECK(std::abs(kept - 1) < 1e-12);
    CHECK(worst < 1e-8);
  }
}

TEST_CASE("chi-square of product samples, pruned and unpruned, both domains", "[sample][product]") {
  // fiber: the heaviest pair sits near theta = 1.4, cut by theta = pi/2; one lobe across the seam
  const SliceMixture fa = mixture({gaussian(0.5, 1.4, 0.5, 0.15, 0.3, 0.2), gaussian(0.3, 0.0, -2.0, 0.3, 0.8, -0.3),
                                   gaussian(0.2, -0.8, 2.8, 0.2, 0.4, 0.1)});
  const SliceMixture fb = mixture({gaussian(0.6, 1.35, 0.8, 0.2, 0.5, 0.0), gaussian(0.4, -0.3, -2.8, 0.4, 1.5, 0.3),
                                   gaussian(0.3, -0.5, 3.1, 0.3, 0.3, -0.2)});
  // hemisphere: lobes cut by theta = 0 and by pi/2
  const SliceMixture ha = mixture({gaussian(0.6, 0.1, 1.0, 0.2, 0.5, 0.3), gaussian(0.4, 1.3, -1.5, 0.15, 0.8, -0.2),
                                   gaussian(0.3, 0.7, 2.9, 0.3, 1.5, 0.0)});
  const SliceMixture hb = mixture({gaussian(0.5, 0.05, 1.4, 0.25, 0.7, -0.1), gaussian(0.3, 1.2, -1.0, 0.3, 1.0, 0.4),
                                   gaussian(0.2, 0.6, -3.0, 0.35, 1.2, 0.2), gaussian(0.2, 0.9, 0.0, 0.4, 2.0, 0.0)});
  struct Case {
    const char* what;
    const SliceMixture *a, *b;
    double rot;
    Domain d;
    std::uint32_t stream;
  };
  const Case cases[] = {{"fiber, cut by theta = pi/2", &fa, &fb, 0.4, Domain::Fiber, 11},
                        {"hemisphere, cut by theta = 0", &ha, &hb, -0.9, Domain::Hemisphere, 13}};
  for (const Case& c : cases) {
    double mass = 0, kept_all = 0, kept4 = 0;
    const SliceMixture full = product(*c.a, c.rot, *c.b, ProductOptions{1.0, 1000}, &mass, &kept_all);
    const SliceMixture pruned = product(*c.a, c.rot, *c.b, ProductOptions{0.999, 4}, &mass, &kept4);
    std::printf("product_test: %s: unpruned %zu components, pruned %zu components keep %.4f of the mass\n", c.what,
                full.components.size(), pruned.components.size(), kept4);
    REQUIRE(pruned.components.size() == 4);
    CHECK(kept4 < 1);
    const std::string w1 = std::string(c.what) + ", unpruned", w2 = std::string(c.what) + ", pruned to 4";
    const double inv1 = check_chi2(full, c.d, c.stream, w1.c_str());
    const double inv2 = check_chi2(pruned, c.d, c.stream + 1, w2.c_str());
    CHECK(inv1 > 0.01);  // the border cuts a visible share of the samples
    CHECK(inv2 > 0.01);
  }
}

TEST_CASE("the product's pdf integrates to its analytic mass inside the theta range", "[sample][product]") {
  const SliceMixture fa = mixture({gaussian(0.5, 1.4, 0.5, 0.15, 0.3, 0.2), gaussian(0.3, 0.0, -2.0, 0.3, 0.8, -0.3),
                                   gaussian(0.2, -0.8, 2.8, 0.2, 0.4, 0.1)});
  const SliceMixture fb = mixture({gaussian(0.6, 1.35, 0.8, 0.2, 0.5, 0.0), gaussian(0.4, -0.3, -2.8, 0.4, 1.5, 0.3),
                                   gaussian(0.3, -0.5, 3.1, 0.3, 0.3, -0.2)});
  const SliceMixture a = broad_a(), b = broad_b();
  struct Case {
    const char* what;
    const SliceMixture *a, *b;
    Domain d;
  };
  const Case cases[] = {{"fiber, cut lobe", &fa, &fb, Domain::Fiber},
                        {"broad, fiber", &a, &b, Domain::Fiber},
                        {"broad, hemisphere", &a, &b, Domain::Hemisphere}};
  for (const Case& c : cases)
    for (const std::size_t maxc : {std::size_t(1000), std::size_t(3)}) {
      const SliceMixture p = product(*c.a, 0.25, *c.b, ProductOptions{maxc == 1000 ? 1.0 : 0.999, maxc});
      const double lo = theta_lo(c.d), hi = theta_hi(c.d);
      const double q = quadrature_mass(p, lo, hi), an = analytic_mass(p, lo, hi);
      std::printf("product_test: integral %s, %zu components: quadrature %.9f, analytic %.9f, difference %.2e\n",
                  c.what, p.components.size(), q, an, q - an);
      INFO(c.what << ", " << p.components.size() << " components");
      CHECK(std::abs(q - an) < 1e-6);
      CHECK(an < 1.0);
    }
}

TEST_CASE("pruning keeps the heaviest pairs; MixtureSet::product_with is the product of the blend",
          "[sample][product]") {
  // a: 3 components, b: 2; narrow enough that each pair has one dominant phi image
  const Gaussian as[3] = {gaussian(0.5, 0.2, 0.3, 0.2, 0.3, 0.3), gaussian(0.3, -0.4, 2.9, 0.25, 0.35, -0.2),
                          gaussian(0.2, 0.0, 1.0, 0.3, 0.5, 0.1)};
  const Gaussian bs[2] = {gaussian(0.6, 0.1, 0.6, 0.3, 0.4, -0.3), gaussian(0.4, -0.2, -2.9, 0.3, 0.6, 0.4)};
  const SliceMixture a = mixture({as[0], as[1], as[2]}), b = mixture({bs[0], bs[1]});
  // independent pair weights w_i w_j N(mu_i; mu_j, S_i + S_j): each pair's nearest image,
  // and the total over every image (|d| <= 4)
  std::vector<double> nearest;
  double total = 0;
  for (const Gaussian& x : as)
    for (const Gaussian& y : bs) {
      const double wi = x.weight / 1.0, wj = y.weight / 1.0;  // both sets of weights sum to 1 already
      const Sym s = add(cov(x), cov(y));
      double best = 0;
      for (int d = -4; d <= 4; ++d) {
        const double c = wi * wj * normal({x.mu_t, x.mu_p + 2 * kPi * d}, {y.mu_t, y.mu_p}, s);
        total += c;
        best = std::max(best, c);
      }
      nearest.push_back(best);
    }
  std::sort(nearest.rbegin(), nearest.rend());
  const double expect_kept = (nearest[0] + nearest[1]) / total;
  double mass = 0, kept = 0;
  const SliceMixture p = product(a, 0.0, b, ProductOptions{1.0, 2}, &mass, &kept);
  std::printf("product_test: pruning to 2 of 6 pairs: kept %.15f, expected %.15f (rel %.2e); mass %.15g vs %.15g\n",
              kept, expect_kept, rel(kept, expect_kept), mass, total);
  REQUIRE(p.components.size() == 2);
  CHECK(kept < 0.95);
  CHECK(rel(kept, expect_kept) < 1e-12);
  CHECK(rel(mass, total) < 1e-12);
  CHECK(rel(p.components[0].weight, nearest[0] / (nearest[0] + nearest[1])) < 1e-12);
  CHECK(rel(p.components[1].weight, nearest[1] / (nearest[0] + nearest[1])) < 1e-12);

  // product_with on a 2-slice azimuthal fiber set, theta_o between the slices
  MixtureSet set;
  set.domain = Domain::Fiber;
  set.azimuthal = true;
  set.grid_theta_o = {-0.4, 0.6};
  set.grid_phi_o = {0.0};
  SliceMixture s0, s1;
  s0.theta_o = -0.4;
  s0.scale = 0.8;
  s0.components = {gaussian(0.6, 0.3, 2.8, 0.2, 0.4, 0.3), gaussian(0.4, -0.7, -0.5, 0.3, 1.2, -0.2)};
  s1.theta_o = 0.6;
  s1.scale = 1.2;
  s1.components = {gaussian(0.7, -0.1, 0.4, 0.15, 0.3, 0.5), gaussian(0.3, 1.1, -2.7, 0.25, 0.9, 0.0),
                   gaussian(0.2, 0.5, 1.5, 0.3, 1.5, 0.1)};
  set.slices = {s0, s1};
  set.prepare();
  const SliceMixture light = mixture({gaussian(0.5, 0.4, -2.6, 0.3, 0.5, 0.2), gaussian(0.3, -0.2, 1.2, 0.5, 1.4, -0.1),
                                      gaussian(0.2, 0.9, 3.0, 0.2, 0.3, 0.0)});
  const double to = 0.1, po = 1.0;
  for (const ProductOptions& o : {ProductOptions{}, ProductOptions{1.0, 1000}}) {
    double m1 = 0, k1 = 0, m2 = 0, k2 = 0;
    const SliceMixture x = set.product_with(to, po, light, o, &m1, &k1);
    const SliceMixture y = product(set.blended(to, po), 0.0, light, o, &m2, &k2);
    REQUIRE(x.components.size() == y.components.size());
    double worst = std::max(rel(m1, m2), rel(k1, k2));
    for (std::size_t k = 0; k < x.components.size(); ++k) {
      const Gaussian &g = x.components[k], &h = y.components[k];
      for (const auto& pr : {std::make_pair(g.weight, h.weight), std::make_pair(g.mu_t, h.mu_t),
                             std::make_pair(g.mu_p, h.mu_p), std::make_pair(g.s_tt, h.s_tt),
                             std::make_pair(g.s_tp, h.s_tp), std::make_pair(g.s_pp, h.s_pp)})
        worst = std::max(worst, std::abs(pr.first - pr.second) / std::max(std::abs(pr.second), 1.0));
    }
    std::printf("product_test: product_with (theta_o %.1f, phi_o %.1f, keep %.3f, max %zu): %zu components, kept "
                "%.6f, mass %.9g, worst difference to product(blended) %.2e\n",
                to, po, o.keep, o.max_components, x.components.size(), k1, m1, worst);
    CHECK(worst < 1e-14);
    if (o.max_components == 1000) {
      std::vector<double> ref, got;
      double vmax = 0;
      for (int i = 0; i < 60; ++i)
        for (int j = 0; j < 120; ++j) {
          const double th = -kPi / 2 + kPi * (i + 0.5) / 60, ph = -kPi + 2 * kPi * (j + 0.1) / 120;
          ref.push_back(set.pdf_param(to, po, th, ph) * light.pdf_param(th, ph));
          got.push_back(x.pdf_param(th, ph) * m1);
          vmax = std::max(vmax, ref.back());
        }
      double w = 0;
      for (std::size_t k = 0; k < ref.size(); ++k)
        if (ref[k] > 1e-12 * vmax) w = std::max(w, rel(got[k], ref[k]));
      std::printf("product_test: product_with unpruned: pdf*mass = set.pdf_param * light.pdf_param, worst rel error "
                  "%.2e\n",
                  w);
      CHECK(w < 1e-9);
    }
  }
}

TEST_CASE("on the disk a base takes part as its 7-Gaussian fit of the cosine dome", "[sample][product]") {
  // The fit against (1 - |x|^2 / 2) / pi over the plane (its mass past the horizon counts).
  const std::vector<Gaussian> parts = base_gaussians(0.25);
  double wsum = 0;
  for (const Gaussian& g : parts) wsum += g.weight;
  const double h = 0.01;
  double l1 = 0, outside = 0;
  for (double x = -2.8 + h / 2; x < 2.8; x += h)
    for (double y = -2.8 + h / 2; y < 2.8; y += h) {
      double q = 0;
      for (const Gaussian& g : parts) q += g.weight / 0.25 * g.density(x, y);
      l1 += std::abs(q - lambert_base(x, y)) * h * h;
      if (x * x + y * y > 2) outside += q * h * h;
    }
  std::printf("product_test: the base's fit: %zu Gaussians, weights %.15f of the base, L1 %.4f from the dome, %.4f "
              "of it past the horizon\n",
              parts.size(), wsum / 0.25, l1, outside);
  CHECK(parts.size() == 7);
  CHECK(std::abs(wsum - 0.25) < 1e-15);
  CHECK(l1 < 0.08);  // one isotropic Gaussian of sigma 0.75: 0.40
  CHECK(outside < 0.03);

  // A base and a lobe times a lobe: pdf * mass is (the base's fit + the lobe) * the lobe,
  // and the product is within a few percent of the true (dome + lobe) * lobe.
  SliceMixture a = mixture({gaussian(0.4, 0.3, -0.5, 0.2, 0.25, 0.1)});
  a.map = Map::Disk;
  a.components[0].weight = 0.4;
  a.base = 0.6;
  a.prepare();
  SliceMixture b = mixture({gaussian(1.0, 0.6, -0.4, 0.35, 0.3, 0.1)});
  b.map = Map::Disk;
  b.prepare();
  double mass = 0, kept = 0;
  const SliceMixture p = product(a, 0.0, b, ProductOptions{1.0, 1000}, &mass, &kept);
  double worst = 0, vmax = 0, l1p = 0, norm = 0;
  std::vector<double> ref, got, exact;
  for (double x = -1.6 + h / 2; x < 1.6; x += 2 * h)
    for (double y = -1.6 + h / 2; y < 1.6; y += 2 * h) {
      double fit = 0;
      for (const Gaussian& g : base_gaussians(a.base)) fit += g.weight * g.density(x, y);
      fit += a.components[0].weight * a.components[0].density(x, y);
      ref.push_back(fit * b.pdf_map(x, y));
      got.push_back(p.pdf_map(x, y) * mass);
      exact.push_back(a.pdf_map(x, y) * b.pdf_map(x, y));
      norm += exact.back() * 4 * h * h;
      vmax = std::max(vmax, ref.back());
    }
  for (std::size_t k = 0; k < ref.size(); ++k) {
    if (ref[k] > 1e-12 * vmax) worst = std::max(worst, rel(got[k], ref[k]));
    l1p += std::abs(got[k] / mass - exact[k] / norm) * 4 * h * h;
  }
  std::printf("product_test: a base and a lobe times a lobe on the disk: %zu components, identity worst rel error "
              "%.2e, L1 %.4f from the exact product\n",
              p.components.size(), worst, l1p);
  CHECK(p.map == Map::Disk);
  CHECK(worst < 1e-6);
  CHECK(l1p < 0.02);  // one Gaussian of sigma 0.75 for the base: 0.042
}
