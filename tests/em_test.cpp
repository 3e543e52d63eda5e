// kernels/em.cl against its CPU reference (host/fit/em_reference.cpp), and the EM
// behaviour both share: known mixtures recovered, periodic phi, extreme weights,
// zero slices, results independent of batching.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdlib>
#include <limits>
#include <set>
#include <sstream>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "core/progress.hpp"
#include "fit/em.hpp"
#include "fit/em_internal.hpp"
#include "fit/synthetic.hpp"
#include "kernel_shapes.hpp"

using namespace bsdfmix;

namespace {

Gmm lobe(double wt, double mt, double mp, double st, double sp, double rho) {
  Gmm g;
  g.weight = {wt};
  g.mean = {mt, mp};
  g.cov = {st * st, rho * st * sp, sp * sp};
  return g;
}

Gmm join(std::vector<Gmm> parts) {
  Gmm g;
  double s = 0;
  for (const auto& p : parts) {
    g.weight.insert(g.weight.end(), p.weight.begin(), p.weight.end());
    g.mean.insert(g.mean.end(), p.mean.begin(), p.mean.end());
    g.cov.insert(g.cov.end(), p.cov.begin(), p.cov.end());
    s += p.weight[0];
  }
  for (double& w : g.weight) w /= s;
  return g;
}

// Three separated lobes, one across phi = +-pi.
Gmm three_lobes() {
  return join({lobe(0.5, 0.3, 0.4, 0.12, 0.25, 0.3), lobe(0.3, -0.5, 3.0, 0.15, 0.3, -0.2),
               lobe(0.2, 0.6, -1.8, 0.1, 0.2, 0.0)});
}

EmEngine& engine(EmPrecision p) {
  static EmEngine fp64(select_devices(""), 1, EmPrecision::Auto);
  static EmEngine fp32(select_devices(""), 1, EmPrecision::Fp32);
  return p == EmPrecision::Fp32 ? fp32 : fp64;
}

double phi_dist(double a, double b) { return std::abs(wrap_phi(a - b)); }

// Largest differences between two mixtures with the same component order.
struct Diff {
  double weight = 0, mean = 0, cov_rel = 0;
};
Diff compare(const Gmm& a, const Gmm& b) {
  Diff d;
  REQUIRE(a.k() == b.k());
  for (int j = 0; j < a.k(); ++j) {
    d.weight = std::max(d.weight, std::abs(a.weight[j] - b.weight[j]));
    d.mean = std::max(d.mean, std::abs(a.mean[2 * j] - b.mean[2 * j]));
    d.mean = std::max(d.mean, phi_dist(a.mean[2 * j + 1], b.mean[2 * j + 1]));
    const double scale = std::sqrt(a.cov[3 * j] * a.cov[3 * j + 2]);
    for (int q = 0; q < 3; ++q) d.cov_rel = std::max(d.cov_rel, std::abs(a.cov[3 * j + q] - b.cov[3 * j + q]) / scale);
  }
  return d;
}

// A kernel result against the reference's: the same iterations, and parameters within
// float rounding. Measured: |dL| <= 2e-7, weights 2e-7, means 1e-6 rad, covariances 2e-5
// relative.
void check_matches(const EmResult& got, const EmResult& ref) {
  CHECK(got.iterations == ref.iterations);
  CHECK(std::abs(got.loglik - ref.loglik) < 2e-5);
  const Diff d = compare(got.gmm, ref.gmm);
  CHECK(d.weight < 2e-5);
  CHECK(d.mean < 5e-5);
  CHECK(d.cov_rel < 5e-4);
}

// For each true component, the fitted one nearest to it.
int nearest(const Gmm& fit, double mt, double mp) {
  int best = 0;
  double bd = 1e300;
  for (int j = 0; j < fit.k(); ++j) {
    const double d = std::hypot(fit.mean[2 * j] - mt, phi_dist(fit.mean[2 * j + 1], mp));
    if (d < bd) bd = d, best = j;
  }
  return best;
}

EmSettings fixed(int iterations, int restarts = 1) {
  EmSettings s;
  s.iterations = iterations;
  s.tolerance = 0;
  s.restarts = restarts;
  s.seed = 7;
  return s;
}

struct Quiet {
  Quiet() { Progress::set_enabled(false); }
} quiet;

}  // namespace

TEST_CASE("gmm_density is a density over the periodic domain", "[em]") {
  const SliceGrid g = make_slice_grid(Domain::Fiber, 180, 360);
  const Gmm m = join({lobe(1, 0.0, kPi - 0.02, 0.1, 0.4, 0.3)});
  const auto w = mixture_weights(g, m);
  double s = 0;
  for (double v : w) s += v;
  s *= axis_step(g.theta) * axis_step(g.phi);
  CHECK(s == Approx(1.0).epsilon(1e-4));
  // Across phi = +-pi the density is continuous.
  CHECK(gmm_density(m, 0.0, kPi - 1e-9) == Approx(gmm_density(m, 0.0, -kPi + 1e-9)).epsilon(1e-6));
}

TEST_CASE("kernels match the reference for several K, both precisions", "[em]") {
  SliceSet set;
  set.grid = make_slice_grid(Domain::Fiber, 45, 90);
  set.weights = {mixture_weights(set.grid, three_lobes())};
  std::vector<EmTask> tasks;
  for (int k : {1, 2, 3, 5, 8}) tasks.push_back({0, k, fixed(25)});
  // A high re-seed threshold makes components empty and re-seeded on both sides.
  EmTask reseed{0, 6, fixed(25)};
  reseed.settings.min_weight = 0.12;
  tasks.push_back(reseed);
  const auto ref = em_fit_reference(set, tasks);
  for (EmPrecision prec : {EmPrecision::Auto, EmPrecision::Fp32}) {
    const auto got = engine(prec).fit(set, tasks);
    for (std::size_t i = 0; i < tasks.size(); ++i) {
      INFO("precision " << precision_name(prec) << ", K = " << tasks[i].k);
      REQUIRE(ref[i].ok);
      REQUIRE(got[i].ok);
      check_matches(got[i], ref[i]);
    }
  }
}

// The programs of the equal-area maps (-DMAP=1, 2): the cells at their map points, against the
// reference's cell_point. On the cylinder the three lobes' theta means are x = sin theta
// (all inside [-1, 1]); on the disk, lobes at the pole, inside and at the rim.
TEST_CASE("kernels match the reference on the equal-area maps, both precisions", "[em]") {
  for (const Map map : {Map::Cylinder, Map::Disk}) {
    SliceSet set;
    set.grid = make_slice_grid(map == Map::Disk ? Domain::Hemisphere : Domain::Fiber, 45, 90);
    set.grid.map = map;
    const Gmm truth = map == Map::Disk ? join({lobe(0.4, 0.02, -0.03, 0.1, 0.12, 0.2), lobe(0.4, 0.6, 0.5, 0.15, 0.2, -0.3),
                                               lobe(0.2, -1.2, 0.4, 0.12, 0.25, 0.1)})
                                       : three_lobes();
    set.weights = {mixture_weights(set.grid, truth)};
    std::vector<EmTask> tasks;
    for (int k : {1, 3, 5}) tasks.push_back({0, k, fixed(25)});
    const auto ref = em_fit_reference(set, tasks);
    for (EmPrecision prec : {EmPrecision::Auto, EmPrecision::Fp32}) {
      const auto got = engine(prec).fit(set, tasks);
      for (std::size_t i = 0; i < tasks.size(); ++i) {
        INFO("map " << map_name(map) << ", precision " << precision_name(prec) << ", K = " << tasks[i].k);
        REQUIRE(ref[i].ok);
        REQUIRE(got[i].ok);
        check_matches(got[i], ref[i]);
      }
    }
  }
}

// Every K_MAX bucket the engine compiles (k_bucket: 4, 8, ..., 128 for kEmMaxK, the
// largest K it and a config accept), each at a K inside it, K = 50 among them, in every
// kernel shape (tests/kernel_shapes.hpp). A slice of many
// lobes, so that large K spreads over structure instead of re-seeding empty components.
TEST_CASE("kernels match the reference in every K bucket the engine compiles", "[em][buckets]") {
  SliceSet set;
  set.grid = make_slice_grid(Domain::Fiber, 90, 180);
  std::vector<Gmm> lobes;
  for (int i = 0; i < 24; ++i) {
    const double u = (i * 0.618034) - std::floor(i * 0.618034), v = (i * 0.754878) - std::floor(i * 0.754878);
    lobes.push_back(lobe(0.5 + u, -1.2 + 2.4 * u, -kPi + 2 * kPi * v, 0.06 + 0.1 * v, 0.1 + 0.2 * u, 0.4 * (u - v)));
  }
  set.weights = {mixture_weights(set.grid, join(lobes))};
  for (double& w : set.weights[0]) w += 2e-3;  // a floor: no cell is empty
  const std::vector<int> ks = {3, 8, 12, 24, 50, 100};
  std::set<int> buckets;
  std::vector<EmTask> tasks;
  for (int k : ks) {
    EmTask t{0, k, fixed(k <= 50 ? 12 : 6)};
    tasks.push_back(t);
    buckets.insert(em_detail::k_bucket(k));
  }
  CHECK(buckets == std::set<int>{4, 8, 16, 32, 64, 128});
  CHECK(em_detail::k_bucket(kEmMaxK) == 128);  // no K the engine accepts needs a larger bucket
  const auto ref = em_fit_reference(set, tasks);
  for (const test::ShapeRun& run : test::shape_runs()) {
    const auto got = test::shape_engine(run)->fit(set, tasks);
    for (std::size_t i = 0; i < tasks.size(); ++i) {
      INFO(run.label() << ", K = " << tasks[i].k << " (bucket " << em_detail::k_bucket(tasks[i].k) << ")");
      REQUIRE(ref[i].ok);
      REQUIRE(got[i].ok);
      check_matches(got[i], ref[i]);
    }
  }
}

TEST_CASE("the GPU layout (scalar work-items, local reductions) matches the reference", "[em]") {
  SliceSet set;
  set.grid = make_slice_grid(Domain::Fiber, 45, 90);
  set.weights = {mixture_weights(set.grid, three_lobes())};
  std::vector<EmTask> tasks;
  for (int k : {1, 3, 7}) tasks.push_back({0, k, fixed(20)});
  const auto ref = em_fit_reference(set, tasks);
  for (EmPrecision prec : {EmPrecision::Auto, EmPrecision::Fp32}) {
    EmEngine gpu(select_devices(""), 1, prec);
    gpu.set_gpu_layout(true);
    const auto got = gpu.fit(set, tasks);
    for (std::size_t i = 0; i < tasks.size(); ++i) {
      INFO("precision " << precision_name(prec) << ", K = " << tasks[i].k);
      REQUIRE(got[i].ok);
      check_matches(got[i], ref[i]);
    }
  }
}

TEST_CASE("a lobe across phi = +-pi fits as well as the same lobe at the center", "[em]") {
  // Shifting by half the phi cells moves the lobe exactly by pi on the grid.
  SliceSet set;
  set.grid = make_slice_grid(Domain::Fiber, 60, 120);
  const Gmm center = join({lobe(0.7, 0.2, 0.0 + 0.5 * axis_step(set.grid.phi), 0.15, 0.3, 0.4),
                           lobe(0.3, -0.4, 1.2, 0.1, 0.2, 0.0)});
  Gmm edge = center;
  for (int j = 0; j < edge.k(); ++j) edge.mean[2 * j + 1] = wrap_phi(edge.mean[2 * j + 1] + kPi);
  set.weights = {mixture_weights(set.grid, center), mixture_weights(set.grid, edge)};
  EmSettings s;
  s.iterations = 300;
  s.tolerance = 1e-10;
  s.restarts = 2;
  const std::vector<EmTask> tasks = {{0, 2, s}, {1, 2, s}};
  for (bool reference : {true, false}) {
    const auto r = reference ? em_fit_reference(set, tasks) : engine(EmPrecision::Auto).fit(set, tasks);
    INFO((reference ? "reference" : "kernel"));
    REQUIRE(r[0].ok);
    REQUIRE(r[1].ok);
    CHECK(std::abs(r[0].loglik - r[1].loglik) < 1e-4);
    for (int j = 0; j < 2; ++j) {
      const int a = nearest(r[0].gmm, center.mean[2 * j], center.mean[2 * j + 1]);
      const int b = nearest(r[1].gmm, edge.mean[2 * j], edge.mean[2 * j + 1]);
      CHECK(std::abs(r[0].gmm.weight[a] - r[1].gmm.weight[b]) < 1e-3);
      CHECK(std::abs(r[0].gmm.mean[2 * a] - r[1].gmm.mean[2 * b]) < 1e-3);
      CHECK(phi_dist(r[0].gmm.mean[2 * a + 1] + kPi, r[1].gmm.mean[2 * b + 1]) < 1e-3);
      for (int q = 0; q < 3; ++q)
        CHECK(std::abs(r[0].gmm.cov[3 * a + q] - r[1].gmm.cov[3 * b + q]) < 2e-3 * r[0].gmm.cov[3 * a + 2]);
      // Both recover the true lobe.
      CHECK(std::abs(r[1].gmm.weight[b] - edge.weight[j]) < 0.01);
      CHECK(phi_dist(r[1].gmm.mean[2 * b + 1], edge.mean[2 * j + 1]) < 0.01);
    }
  }
}

TEST_CASE("10^5 cells with weights spanning 1e-8..1e8 stay accurate in both precisions", "[em]") {
  SliceSet set;
  set.grid = make_slice_grid(Domain::Hemisphere, 250, 400);
  auto w = mixture_weights(set.grid, three_lobes());
  // Multiply by factors 10^-8 .. 10^8 in a deterministic pattern; a slab of huge
  // weights and a sea of tiny ones.
  for (std::size_t i = 0; i < w.size(); ++i) w[i] *= std::pow(10.0, -8.0 + 16.0 * double((i * 7919) % 1000) / 999.0);
  set.weights = {w};
  const std::vector<EmTask> tasks = {{0, 3, fixed(15)}, {0, 6, fixed(15)}};
  const auto ref = em_fit_reference(set, tasks);
  for (EmPrecision prec : {EmPrecision::Auto, EmPrecision::Fp32}) {
    const auto got = engine(prec).fit(set, tasks);
    for (std::size_t i = 0; i < tasks.size(); ++i) {
      INFO("precision " << precision_name(prec) << ", K = " << tasks[i].k);
      REQUIRE(got[i].ok);
      CHECK(std::abs(got[i].loglik - ref[i].loglik) < 2e-5 * std::max(1.0, std::abs(ref[i].loglik)));
      const Diff d = compare(got[i].gmm, ref[i].gmm);
      CHECK(d.weight < 2e-5);
      CHECK(d.mean < 5e-5);
      CHECK(d.cov_rel < 5e-4);
    }
  }
}

TEST_CASE("slices that are known mixtures are recovered", "[em]") {
  SliceSet set;
  set.grid = make_slice_grid(Domain::Fiber, 90, 180);
  const std::vector<Gmm> truth = {three_lobes(),
                                  join({lobe(0.6, -0.2, -3.0, 0.1, 0.3, 0.5), lobe(0.4, 0.5, 1.0, 0.2, 0.15, -0.3)})};
  for (const auto& t : truth) set.weights.push_back(mixture_weights(set.grid, t));
  EmSettings s;
  s.iterations = 400;
  s.tolerance = 1e-9;
  s.restarts = 3;
  const std::vector<EmTask> tasks = {{0, 3, s}, {1, 2, s}};
  const auto got = engine(EmPrecision::Auto).fit(set, tasks);
  const auto ref = em_fit_reference(set, tasks);
  for (std::size_t i = 0; i < tasks.size(); ++i) {
    INFO("slice " << i);
    REQUIRE(got[i].ok);
    CHECK(got[i].loglik >= ref[i].loglik - 1e-5);
    const Gmm& t = truth[i];
    for (int j = 0; j < t.k(); ++j) {
      const int f = nearest(got[i].gmm, t.mean[2 * j], t.mean[2 * j + 1]);
      const Gmm& g = got[i].gmm;
      CHECK(std::abs(g.weight[f] - t.weight[j]) < 0.01);
      CHECK(std::abs(g.mean[2 * f] - t.mean[2 * j]) < 0.01);
      CHECK(phi_dist(g.mean[2 * f + 1], t.mean[2 * j + 1]) < 0.01);
      for (int q : {0, 2}) CHECK(g.cov[3 * f + q] == Approx(t.cov[3 * j + q]).epsilon(0.05));
      CHECK(std::abs(g.cov[3 * f + 1] - t.cov[3 * j + 1]) < 0.05 * std::sqrt(t.cov[3 * j] * t.cov[3 * j + 2]));
    }
  }
}

TEST_CASE("a zero slice and too few cells fail with a reason, never NaN", "[em]") {
  SliceSet set;
  set.grid = make_slice_grid(Domain::Fiber, 20, 40);
  set.weights = {std::vector<double>(800, 0.0), std::vector<double>(800, 0.0)};
  set.weights[1][5] = 1.0;
  set.weights[1][100] = 2.0;
  const std::vector<EmTask> tasks = {{0, 2, fixed(5)}, {1, 3, fixed(5)}, {1, 2, fixed(5)}};
  for (int pass = 0; pass < 2; ++pass) {
    const auto r = pass == 0 ? em_fit_reference(set, tasks) : engine(EmPrecision::Auto).fit(set, tasks);
    CHECK_FALSE(r[0].ok);
    CHECK(r[0].failure.find("zero total weight") != std::string::npos);
    CHECK_FALSE(std::isnan(r[0].loglik));
    CHECK_FALSE(r[1].ok);
    CHECK(r[1].failure.find("fewer than K") != std::string::npos);
    // Two cells, two components: fits, the floor keeps the covariances finite.
    REQUIRE(r[2].ok);
    CHECK(std::isfinite(r[2].loglik));
  }
  set.weights[1][7] = -1.0;
  CHECK_THROWS_AS(em_fit_reference(set, tasks), InputError);
  set.weights[1][7] = 0.0;
  CHECK_THROWS_AS(engine(EmPrecision::Auto).fit(set, {{0, kEmMaxK + 1, fixed(1)}}), ConfigError);
}

TEST_CASE("results do not depend on the batch size", "[em]") {
  SliceSet set;
  set.grid = make_slice_grid(Domain::Fiber, 30, 60);
  for (int s = 0; s < 4; ++s) set.weights.push_back(mixture_weights(set.grid, synthetic_lobes(Domain::Fiber, 3, s + 1)));
  std::vector<EmTask> tasks;
  EmSettings st;
  st.iterations = 30;
  st.restarts = 2;
  for (std::size_t s = 0; s < 4; ++s)
    for (int k = 1; k <= 6; ++k) tasks.push_back({s, k, st});
  EmEngine big(select_devices(""), 1);
  EmEngine small(select_devices(""), 1);
  small.set_batch_budget(1);
  const auto a = big.fit(set, tasks);
  const auto b = small.fit(set, tasks);
  CHECK(small.last_timing().batches > big.last_timing().batches);
  for (std::size_t i = 0; i < tasks.size(); ++i) {
    REQUIRE(a[i].ok);
    CHECK(a[i].loglik == b[i].loglik);
    CHECK(a[i].iterations == b[i].iterations);
    CHECK(a[i].gmm.mean == b[i].gmm.mean);
    CHECK(a[i].gmm.cov == b[i].gmm.cov);
    CHECK(a[i].gmm.weight == b[i].gmm.weight);
  }
}

TEST_CASE("initialization is deterministic for a seed and differs across restarts", "[em]") {
  const SliceGrid g = make_slice_grid(Domain::Fiber, 30, 60);
  const auto w0 = mixture_weights(g, three_lobes());
  double s = 0;
  for (double v : w0) s += v;
  std::vector<double> w = w0;
  for (double& v : w) v /= s;
  EmSettings st;
  const Gmm a = em_detail::initialize(g, w, 3, 4, 0, st);
  const Gmm b = em_detail::initialize(g, w, 3, 4, 0, st);
  const Gmm c = em_detail::initialize(g, w, 3, 4, 1, st);
  CHECK(a.mean == b.mean);
  CHECK(a.cov == b.cov);
  CHECK(a.mean != c.mean);
  double ws = 0;
  for (double v : a.weight) ws += v;
  CHECK(ws == Approx(1.0));
}

// A measurement (hidden: run it by its tag): the largest differences between the kernels
// and the reference over the setup docs/em.md describes ("Kernel vs reference"), per
// precision. With BSDFMIX_MEASURE_CSV set it writes them there (bench/reproduce.sh
// em_precision: bench/results/em_precision.csv, the table of docs/em.md).
TEST_CASE("measure: kernels against the reference", "[.measure]") {
  struct Case {
    SliceSet set;
    int iterations;
  };
  std::vector<Case> cases(2);
  cases[0].set.grid = make_slice_grid(Domain::Fiber, 90, 180);
  cases[0].set.weights = {mixture_weights(cases[0].set.grid, three_lobes()),
                          mixture_weights(cases[0].set.grid, synthetic_lobes(Domain::Fiber, 6, 1))};
  cases[0].iterations = 50;
  cases[1].set.grid = make_slice_grid(Domain::Hemisphere, 250, 400);
  auto w = mixture_weights(cases[1].set.grid, three_lobes());
  for (std::size_t i = 0; i < w.size(); ++i) w[i] *= std::pow(10.0, -8.0 + 16.0 * double((i * 7919) % 1000) / 999.0);
  cases[1].set.weights = {w};
  cases[1].iterations = 15;
  std::ostringstream csv;
  csv << "precision,loglik_abs,weight_abs,mean_rad,cov_rel,iterations_equal,fits\n";
  for (EmPrecision prec : {EmPrecision::Auto, EmPrecision::Fp32}) {
    double dl = 0;
    Diff worst;
    int equal = 0, fits = 0;
    for (const Case& c : cases) {
      std::vector<EmTask> tasks;
      for (std::size_t s = 0; s < c.set.weights.size(); ++s)
        for (int k : {1, 3, 8, 16, 32}) tasks.push_back({s, k, fixed(c.iterations)});
      const auto ref = em_fit_reference(c.set, tasks);
      const auto got = engine(prec).fit(c.set, tasks);
      for (std::size_t i = 0; i < tasks.size(); ++i) {
        REQUIRE(ref[i].ok);
        REQUIRE(got[i].ok);
        ++fits;
        equal += got[i].iterations == ref[i].iterations;
        dl = std::max(dl, std::abs(got[i].loglik - ref[i].loglik) / std::max(1.0, std::abs(ref[i].loglik)));
        const Diff d = compare(got[i].gmm, ref[i].gmm);
        worst.weight = std::max(worst.weight, d.weight);
        worst.mean = std::max(worst.mean, d.mean);
        worst.cov_rel = std::max(worst.cov_rel, d.cov_rel);
      }
    }
    std::printf("%s: loglik %.2g, weights %.2g, means %.2g rad, covariances %.2g relative; iterations equal %d of %d\n",
                precision_name(prec).c_str(), dl, worst.weight, worst.mean, worst.cov_rel, equal, fits);
    csv << precision_name(prec) << "," << dl << "," << worst.weight << "," << worst.mean << ","
        << worst.cov_rel << "," << equal << "," << fits << "\n";
  }
  if (const char* path = std::getenv("BSDFMIX_MEASURE_CSV")) write_text_atomic(path, csv.str());
}
