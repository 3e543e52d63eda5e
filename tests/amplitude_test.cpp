// Channel amplitudes of fixed Gaussians (host/fit/amplitudes.*, kernels/em.cl amp_basis and
// amp_sums): the kernel against its CPU reference in every K bucket and kernel shape;
// the non-negative solve against brute force; known amplitudes recovered exactly; the
// integral kept where a lobe leaks past the border; the header's eval_rgb against the
// reference's stand-in.
// labels: fit
#include <catch2/catch.hpp>

#include <Eigen/Dense>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <random>
#include <set>

#include "core/domain.hpp"
#include "device/device.hpp"
#include "fit/amplitudes.hpp"
#include "fit/em.hpp"
#include "fit/em_internal.hpp"
#include "sweep/fit_error.hpp"
#include "kernel_shapes.hpp"

using namespace bsdfmix;

namespace {

void add(Gmm& g, double w, double mt, double mp, double st, double sp, double rho) {
  g.weight.push_back(w);
  g.mean.insert(g.mean.end(), {mt, mp});
  g.cov.insert(g.cov.end(), {st * st, rho * st * sp, sp * sp});
}

// K components spread over the fiber domain: one across phi = +-pi, one wide in phi (two
// images on each side), the others of various shapes (as tests/refine_test.cpp's); with
// `narrow`, the third narrower than half a cell of a 90 x 180 grid (its cell masses from
// 3 x 3 points).
Gmm spread(int k, bool narrow = true) {
  Gmm g;
  for (int i = 0; i < k; ++i) {
    const double u = (i * 0.618034) - std::floor(i * 0.618034), v = (i * 0.754878) - std::floor(i * 0.754878);
    if (i == 0) add(g, 1.0, 0.2, kPi - 0.05, 0.1, 0.3, 0.2);
    else if (i == 1) add(g, 1.5, -0.4, 0.5, 0.2, 2.2, 0.1);
    else if (i == 2 && narrow) add(g, 0.5, 0.31, -1.02, 0.009, 0.012, 0.3);
    else add(g, 0.5 + u, -1.2 + 2.4 * u, -kPi + 2 * kPi * v, 0.05 + 0.1 * v, 0.08 + 0.2 * u, 0.4 * (u - v));
  }
  return g;
}

double area_of(const SliceGrid& grid) { return axis_step(grid.theta) * axis_step(grid.phi); }

// The stand-in sum_j amp[c][j] area N_j at every cell, through the header (every image).
std::vector<double> header_channels(const SliceGrid& grid, const Gmm& g, const std::vector<double>& amp, int channels) {
  const int K = g.k();
  mix::SliceMixture m = make_slice_mixture(std::vector<double>(std::size_t(K), 1.0 / K), g.mean, g.cov);
  const std::size_t n = grid.cells(), np = grid.phi.size();
  std::vector<double> out(std::size_t(channels) * n, 0.0);
  for (std::size_t i = 0; i < n; ++i)
    for (int j = 0; j < K; ++j) {
      const double d = m.components[std::size_t(j)].density(grid.theta[i / np], grid.phi[i % np]) * area_of(grid);
      for (int c = 0; c < channels; ++c) out[std::size_t(c) * n + i] += amp[std::size_t(c * K + j)] * d;
    }
  return out;
}

EmEngine& device() {
  static EmEngine e(select_devices(""), 1, EmPrecision::Auto);
  return e;
}

AmplitudeEvaluator on_device(EmEngine& e, const ChannelSet& set) {
  auto prepared = std::make_shared<EmEngine::AmpSlices>(EmEngine::amp_prepare(set));
  return [&e, prepared](const std::vector<AmplitudeQuery>& q) { return e.amplitude_sums(*prepared, q); };
}

AmplitudeEvaluator on_reference(const ChannelSet& set) {
  return [&set](const std::vector<AmplitudeQuery>& q) { return amplitude_sums_reference(set, q); };
}

}  // namespace

TEST_CASE("the amplitude kernel matches its reference in every K bucket and kernel shape", "[amplitudes]") {
  const Map map = GENERATE(Map::ThetaPhi, Map::Cylinder, Map::Disk);  // the programs' MAP
  INFO("map " << map_name(map));
  ChannelSet set;
  // 16200 cells: the last chunk is padding in part
  set.grid = make_slice_grid(map == Map::Disk ? Domain::Hemisphere : Domain::Fiber, 90, 180);
  set.grid.map = map;
  set.channels = 4;
  const std::size_t n = set.grid.cells();
  {  // four channels of a mixture, the last one dim and noisy: negative in many cells
    const Gmm truth = spread(6, false);
    std::vector<double> amp(4 * 6);
    for (int c = 0; c < 4; ++c)
      for (int j = 0; j < 6; ++j) amp[std::size_t(c * 6 + j)] = (c == 3 ? 0.05 : 1.0) * (0.2 + 0.1 * ((c + 2 * j) % 5));
    std::vector<double> v = header_channels(set.grid, truth, amp, 4);
    double mean = 0;
    for (std::size_t i = 0; i < n; ++i) mean += v[3 * n + i] / double(n);
    std::mt19937_64 rng(3);
    std::normal_distribution<double> noise(0.0, mean);
    std::size_t negative = 0;
    for (std::size_t i = 0; i < n; ++i) negative += (v[3 * n + i] += noise(rng)) < 0;
    CHECK(negative > n / 10);
    set.values = {v};
  }
  const std::vector<int> ks = {3, 8, 12, 24, 50, 100};
  std::vector<AmplitudeQuery> queries;
  std::set<int> buckets;
  for (std::size_t q = 0; q < ks.size(); ++q) {
    const int k = ks[q];
    AmplitudeQuery a;
    a.slice = 0;
    a.gmm = spread(k);
    for (int c = 0; c < 4; ++c)
      for (int j = 0; j < k; ++j) a.amp.push_back(0.5 * double((j + c) % 3) / k);
    // Even queries reweighted as the fit does (the floor 1e-2 of the channel's mean |w|),
    // odd ones plain least squares.
    a.delta.assign(4, 0.0);
    if (q % 2 == 0)
      for (int c = 0; c < 4; ++c) {
        for (std::size_t i = 0; i < n; ++i) a.delta[std::size_t(c)] += std::abs(set.values[0][std::size_t(c) * n + i]);
        a.delta[std::size_t(c)] *= AmplitudeSettings{}.delta / double(n);
      }
    queries.push_back(a);
    buckets.insert(em_detail::k_bucket(k));
  }
  CHECK(buckets == std::set<int>{4, 8, 16, 32, 64, 128});
  const SliceGrid& grid = set.grid;
  CHECK(sub_cell(queries[0].gmm.cov[6], queries[0].gmm.cov[7], queries[0].gmm.cov[8], axis_step(grid.theta),
                 axis_step(grid.phi)));  // the 3 x 3 path is taken
  const std::vector<AmplitudeSums> ref = amplitude_sums_reference(set, queries);
  for (const test::ShapeRun& run : test::shape_runs()) {
    const std::vector<AmplitudeSums> got = test::shape_engine(run)->amplitude_sums(EmEngine::amp_prepare(set), queries);
    REQUIRE(got.size() == ref.size());
    for (std::size_t i = 0; i < queries.size(); ++i) {
      const int k = queries[i].gmm.k();
      INFO(run.label() << ", K = " << k);
      for (int c = 0; c < 4; ++c) {
        INFO("channel " << c);
        CHECK(got[i].l1[c] == Approx(ref[i].l1[c]).epsilon(1e-4));
        double gscale = 0, bscale = 0;
        for (int a = 0; a < k * k; ++a) gscale = std::max(gscale, std::abs(ref[i].gram[std::size_t(c * k * k + a)]));
        for (int a = 0; a < k; ++a) bscale = std::max(bscale, std::abs(ref[i].rhs[std::size_t(c * k + a)]));
        for (int a = 0; a < k * k; ++a) {
          const double x = got[i].gram[std::size_t(c * k * k + a)], y = ref[i].gram[std::size_t(c * k * k + a)];
          INFO("gram entry " << a << ": " << x << " vs " << y);
          CHECK(std::abs(x - y) <= 2e-4 * gscale);
        }
        for (int a = 0; a < k; ++a) {
          const double x = got[i].rhs[std::size_t(c * k + a)], y = ref[i].rhs[std::size_t(c * k + a)];
          // The reweighted sums carry the float error of the residuals where they are near
          // the floor, the cells that weigh most: ~1e-4 of the largest on the noisy channel.
          INFO("rhs entry " << a << ": " << x << " vs " << y);
          CHECK(std::abs(x - y) <= 5e-4 * bscale);
        }
      }
    }
  }
  // One channel (a table without colour) takes the same path.
  ChannelSet one = set;
  one.channels = 1;
  one.values = {std::vector<double>(set.values[0].begin(), set.values[0].begin() + long(n))};
  std::vector<AmplitudeQuery> q1 = {queries[1]};
  q1[0].amp.resize(std::size_t(q1[0].gmm.k()));
  q1[0].delta = {1e-6};
  const AmplitudeSums r1 = amplitude_sums_reference(one, q1)[0], g1 = device().amplitude_sums(EmEngine::amp_prepare(one), q1)[0];
  CHECK(g1.l1[0] == Approx(r1.l1[0]).epsilon(1e-4));
  CHECK(g1.rhs[0] == Approx(r1.rhs[0]).epsilon(1e-4));
}

TEST_CASE("the non-negative solve is the best of every active set", "[amplitudes]") {
  std::mt19937_64 rng(11);
  std::normal_distribution<double> z(0.0, 1.0);
  for (int trial = 0; trial < 40; ++trial) {
    const int K = 1 + trial % 5, rows = 12;
    std::vector<double> A(std::size_t(rows * K)), y(rows), G(std::size_t(K * K), 0.0), b(std::size_t(K), 0.0);
    for (double& x : A) x = z(rng);
    for (double& x : y) x = z(rng);
    for (int i = 0; i < K; ++i) {
      for (int r = 0; r < rows; ++r) b[std::size_t(i)] += A[std::size_t(r * K + i)] * y[std::size_t(r)];
      for (int j = 0; j < K; ++j)
        for (int r = 0; r < rows; ++r) G[std::size_t(i * K + j)] += A[std::size_t(r * K + i)] * A[std::size_t(r * K + j)];
    }
    auto objective = [&](const std::vector<double>& a) {
      double f = 0;
      for (int i = 0; i < K; ++i) {
        f -= b[std::size_t(i)] * a[std::size_t(i)];
        for (int j = 0; j < K; ++j) f += 0.5 * a[std::size_t(i)] * G[std::size_t(i * K + j)] * a[std::size_t(j)];
      }
      return f;
    };
    const std::vector<double> a = nnls_normal(G, b, K);
    for (double x : a) CHECK(x >= 0);
    // Brute force: the unconstrained optimum on every support, kept when non-negative.
    double best = 0;  // a = 0
    for (int mask = 1; mask < (1 << K); ++mask) {
      std::vector<int> idx;
      for (int i = 0; i < K; ++i)
        if (mask >> i & 1) idx.push_back(i);
      const int m = int(idx.size());
      Eigen::MatrixXd Gp(m, m);
      Eigen::VectorXd bp(m);
      for (int i = 0; i < m; ++i) {
        bp(i) = b[std::size_t(idx[i])];
        for (int j = 0; j < m; ++j) Gp(i, j) = G[std::size_t(idx[i] * K + idx[j])];
      }
      const Eigen::VectorXd x = Gp.ldlt().solve(bp);
      if ((x.array() < 0).any()) continue;
      std::vector<double> full(std::size_t(K), 0.0);
      for (int i = 0; i < m; ++i) full[std::size_t(idx[i])] = x(i);
      best = std::min(best, objective(full));
    }
    CHECK(objective(a) == Approx(best).epsilon(1e-9).margin(1e-12));
  }
}

TEST_CASE("amplitudes of a known mixture with known colours are recovered exactly", "[amplitudes]") {
  ChannelSet set;
  set.grid = make_slice_grid(Domain::Hemisphere, 45, 90);
  set.channels = 4;
  Gmm g;  // four lobes inside the hemisphere, two of them overlapping
  add(g, 1, 0.45, 0.3, 0.1, 0.3, 0.2);
  add(g, 1, 0.7, -2.0, 0.12, 0.5, -0.1);
  add(g, 1, 1.0, 2.5, 0.15, 0.9, 0.0);
  add(g, 1, 0.8, 0.6, 0.1, 0.25, 0.3);
  const double colour[4][3] = {{0.9, 0.2, 0.1}, {0.1, 0.8, 0.3}, {0.4, 0.4, 0.4}, {0.05, 0.1, 0.9}};
  const double lum[4] = {0.3, 0.2, 0.4, 0.1};
  std::vector<double> truth(4 * 4);
  for (int j = 0; j < 4; ++j) {
    truth[std::size_t(j)] = lum[j];
    for (int c = 0; c < 3; ++c) truth[std::size_t((c + 1) * 4 + j)] = lum[j] * colour[j][c];
  }
  set.values = {header_channels(set.grid, g, truth, 4)};
  const std::vector<AmplitudeProblem> problems = {{0, g}};
  const AmplitudeFit ref = fit_amplitudes(on_reference(set), set, problems)[0];
  const AmplitudeFit dev = fit_amplitudes(on_device(device(), set), set, problems)[0];
  for (int q = 0; q < 16; ++q) {
    INFO("channel " << q / 4 << " component " << q % 4);
    CHECK(ref.amp[std::size_t(q)] == Approx(truth[std::size_t(q)]).epsilon(1e-5));
    CHECK(dev.amp[std::size_t(q)] == Approx(ref.amp[std::size_t(q)]).epsilon(1e-4));
  }
}

TEST_CASE("a lobe cut by the theta border keeps its energy in the amplitudes", "[amplitudes]") {
  ChannelSet set;
  set.grid = make_slice_grid(Domain::Hemisphere, 45, 90);
  set.channels = 2;
  Gmm g;  // a lobe centred 0.05 rad above the border at theta = 0: a third of it lies below
  add(g, 1, 0.05, 0.0, 0.12, 0.4, 0.0);
  add(g, 1, 0.9, 2.0, 0.15, 0.5, 0.0);
  const std::vector<double> truth = {0.6, 0.4, 0.2, 0.5};
  set.values = {header_channels(set.grid, g, truth, 2)};
  const std::size_t n = set.grid.cells();
  const double z0 = in_domain_mass(Domain::Hemisphere, 0.05, 0.12 * 0.12);
  CHECK(z0 < 0.7);
  for (const bool on_dev : {false, true}) {
    INFO((on_dev ? "device" : "reference"));
    const AmplitudeFit f = fit_amplitudes(on_dev ? on_device(device(), set) : on_reference(set), set, {{0, g}})[0];
    for (int c = 0; c < 2; ++c) {
      double table = 0, stand_in = 0;
      for (std::size_t i = 0; i < n; ++i) table += set.values[0][std::size_t(c) * n + i];
      for (int j = 0; j < 2; ++j)
        stand_in += f.amp[std::size_t(c * 2 + j)] * in_domain_mass(Domain::Hemisphere, g.mean[2 * j], g.cov[3 * j]);
      CHECK(stand_in == Approx(table).epsilon(1e-9));
      // The leaked lobe's amplitude is its whole mass, not the part the cells hold.
      CHECK(f.amp[std::size_t(c * 2)] == Approx(truth[std::size_t(c * 2)]).epsilon(3e-3));
    }
  }
}

TEST_CASE("the header's eval_rgb is the stand-in the kernel and the reference fit", "[amplitudes]") {
  ChannelSet set;
  set.grid = make_slice_grid(Domain::Hemisphere, 30, 60);
  set.channels = 4;
  const Gmm g = spread(5, false);  // fiber-domain shapes: parts of them leave the hemisphere
  std::vector<double> amp(4 * 5);
  for (std::size_t q = 0; q < amp.size(); ++q) amp[q] = 0.05 + 0.03 * double(q % 7);
  // The header's slice with these amplitudes, its channels at the cell centers as data.
  mix::SliceMixture m = make_slice_mixture(std::vector<double>(5, 0.2), g.mean, g.cov);
  m.has_rgb = true;
  m.scale = 0;
  for (int j = 0; j < 5; ++j) {
    m.scale += amp[std::size_t(j)];
    for (int c = 0; c < 3; ++c) m.components[std::size_t(j)].rgb[c] = amp[std::size_t((c + 1) * 5 + j)];
  }
  for (int j = 0; j < 5; ++j) m.components[std::size_t(j)].weight = amp[std::size_t(j)] / m.scale;
  const std::size_t n = set.grid.cells(), np = set.grid.phi.size();
  const double area = area_of(set.grid);
  std::vector<double> v(4 * n);
  double total = 0;
  for (std::size_t i = 0; i < n; ++i) {
    double c[3];
    m.eval_rgb_param(set.grid.theta[i / np], set.grid.phi[i % np], c);
    v[i] = m.eval_param(set.grid.theta[i / np], set.grid.phi[i % np]) * area;
    for (int ch = 0; ch < 3; ++ch) v[std::size_t(ch + 1) * n + i] = c[ch] * area;
    total += v[i];
  }
  set.values = {v};
  AmplitudeQuery q{0, g, amp, {0.0, 0.0, 0.0, 0.0}};
  const AmplitudeSums ref = amplitude_sums_reference(set, {q})[0];
  const AmplitudeSums dev = device().amplitude_sums(EmEngine::amp_prepare(set), {q})[0];
  for (int c = 0; c < 4; ++c) {
    INFO("channel " << c);
    CHECK(ref.l1[c] <= 1e-8 * total);  // the reference's residuals: the header's stand-in, to rounding
    CHECK(dev.l1[c] <= 2e-5 * total);  // the kernel's, to float
  }
  // MixtureSet::eval_rgb blends like eval_f, and a slice without colour is grey: eval_f itself.
  mix::MixtureSet set2;
  set2.domain = Domain::Hemisphere;
  set2.grid_theta_o = {0.2, 0.6};
  set2.grid_phi_o = {0.0};
  mix::SliceMixture a = m, b = m;
  a.theta_o = 0.2;
  b.theta_o = 0.6;
  b.has_rgb = false;
  set2.slices = {a, b};
  set2.prepare();
  for (const double to : {0.2, 0.3, 0.6}) {
    for (const double t : {0.1, 0.5, 1.2}) {
      double rgb[3];
      set2.eval_rgb(to, 0.4, t, -0.7, rgb);
      const double f = set2.eval_f(to, 0.4, t, -0.7), jc = std::sin(t) * std::cos(t);
      double ca[3];
      set2.slices[0].eval_rgb_param(t, wrap_phi(-0.7 - 0.4), ca);
      const double wa = to == 0.2 ? 1.0 : to == 0.6 ? 0.0 : 0.75;
      const double fb = set2.slices[1].eval_param(t, wrap_phi(-0.7 - 0.4));
      for (int c = 0; c < 3; ++c) CHECK(rgb[c] == Approx((wa * ca[c] + (1 - wa) * fb) / jc).epsilon(1e-12));
      if (to == 0.6)
        for (int c = 0; c < 3; ++c) CHECK(rgb[c] == f);  // bit for bit
    }
  }
}

TEST_CASE("a channel that is noise around zero is fitted for the least L1 error, its sum not kept", "[amplitudes]") {
  ChannelSet set;
  set.grid = make_slice_grid(Domain::Hemisphere, 45, 90);
  set.channels = 2;
  Gmm g;
  add(g, 1, 0.5, 0.0, 0.12, 0.4, 0.0);
  add(g, 1, 0.9, 2.0, 0.15, 0.5, 0.0);
  // Channel 0 clean; channel 1 a faint lobe on a negative bias: its sum is below zero.
  std::vector<double> v = header_channels(set.grid, g, {0.6, 0.4, 0.02, 0.0}, 2);
  const std::size_t n = set.grid.cells();
  double sum = 0, negative = 0, abs_sum = 0;
  for (std::size_t i = 0; i < n; ++i) {
    double& x = v[n + i];
    x -= 1e-5 * (1 + std::sin(double(i)));  // a negative offset, noisy
    sum += x;
    abs_sum += std::abs(x);
    negative += x < 0 ? -x : 0;
  }
  REQUIRE(sum < 0);
  CHECK(is_noise(negative, abs_sum));
  set.values = {v};
  for (const bool on_dev : {false, true}) {
    INFO((on_dev ? "device" : "reference"));
    const AmplitudeFit f = fit_amplitudes(on_dev ? on_device(device(), set) : on_reference(set), set, {{0, g}})[0];
    // The faint lobe is kept (not zeroed for the negative sum), the other component not raised.
    CHECK(f.amp[2] > 0.01);
    CHECK(f.amp[3] < 0.005);
    CHECK(f.l1[1] < 0.9 * abs_sum);  // better than a stand-in of 0, whose error is abs_sum
  }
}

TEST_CASE("the amplitude fit's time on a sweep's slices", "[amplitudes][.measure]") {
  // 90 slices of 90 x 180 cells, K = 10 (the RGL sweeps' mean K is 8 to 10), four channels,
  // in batches of 8 slices as a 90-slice sweep fits them: the fit's cost beside a sweep's.
  ChannelSet set;
  set.grid = make_slice_grid(Domain::Hemisphere, 90, 180);
  set.channels = 4;
  std::vector<AmplitudeProblem> problems;
  Gmm g;
  for (int j = 0; j < 10; ++j) add(g, 1, 0.1 + 0.14 * j, -3.0 + 0.6 * j, 0.1 + 0.02 * j, 0.3 + 0.1 * j, 0.1);
  std::vector<double> amp(40);
  for (std::size_t q = 0; q < amp.size(); ++q) amp[q] = 0.05 + 0.01 * double(q % 9);
  std::vector<double> v = header_channels(set.grid, g, amp, 4);
  for (std::size_t i = 0; i < v.size(); ++i) v[i] *= 1 + 0.3 * std::sin(0.37 * double(i));  // not a mixture
  for (std::size_t s = 0; s < 8; ++s) {
    set.values.push_back(v);
    problems.push_back({s, g});
  }
  const auto t0 = std::chrono::steady_clock::now();
  int evaluations = 0;
  EmEngine& e = device();
  const auto prepared = EmEngine::amp_prepare(set);
  for (int batch = 0; batch < 12; ++batch)  // 96 slices
    fit_amplitudes([&](const std::vector<AmplitudeQuery>& q) { ++evaluations; return e.amplitude_sums(prepared, q); }, set,
                   problems);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("amplitude fit: 96 slices of 90 x 180, K = 10, 4 channels: %.2f s, %d evaluations\n", seconds, evaluations);
}
