// The Gaussian-count search on slices that are known mixtures (2 to 6 components, with
// overlapping pairs, lobes across the phi seam and lobes near the theta border): the
// true K, the recovered parameters, and split-and-merge fits that are never worse than
// plain EM from the same start.
// labels: fit
#include <catch2/catch.hpp>

#include "csv_rows.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <numeric>
#include <random>
#include <cstdio>
#include <sstream>

#include "config/config.hpp"
#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "device/device.hpp"
#include "fit/em.hpp"
#include "fit/em_internal.hpp"
#include "fit/smem.hpp"
#include "fit/synthetic.hpp"
#include "io/mixture_file.hpp"
#include "io/table.hpp"
#include "sweep/criterion.hpp"
#include "sweep/fit_error.hpp"
#include "sweep/sweep.hpp"
#include "tables/rgl_import.hpp"

using namespace bsdfmix;
namespace fs = std::filesystem;

namespace {

fs::path temp_dir() {
  const fs::path d = fs::temp_directory_path() / "bsdfmix_search_test";
  fs::create_directories(d);
  return d;
}

// Uniform [0, 1) from a 64-bit generator whose output the standard fixes.
struct Uniform {
  std::mt19937_64 g;
  explicit Uniform(std::uint64_t seed) : g(seed) {}
  double operator()() { return double(g() >> 11) * 0x1.0p-53; }
  double operator()(double lo, double hi) { return lo + (hi - lo) * (*this)(); }
};

enum class Case { Plain, Overlap, Seam, Border };

struct Known {
  Gmm gmm;
  Case kind = Case::Plain;
};

double wrapped(double d) { return d - 2 * kPi * std::nearbyint(d / (2 * kPi)); }

// A random mixture of k components in the fiber domain, with one special case: two
// components 0.13 rad apart (overlap), one whose phi spread crosses +-pi (seam), or
// one whose mean lies 2.5 to 3 standard deviations inside the theta border (border).
// Other pairs are at least 3 combined standard deviations apart, so k is the truth.
Known random_known(int k, Case kind, std::uint64_t seed) {
  Uniform u(seed);
  for (int attempt = 0;; ++attempt) {
    Known out;
    out.kind = kind;
    Gmm& g = out.gmm;
    std::vector<double> st(k), sp(k);
    for (int j = 0; j < k; ++j) {
      st[j] = u(0.06, 0.16);
      sp[j] = u(0.10, 0.35);
      double mt = u(-1.1, 1.1), mp = u(-kPi, kPi);
      if (kind == Case::Overlap && j == 1) {  // beside component 0, 0.13 rad apart
        st[0] = st[1] = 0.04;
        g.cov[0] = st[0] * st[0];
        g.cov[1] = 0;
        g.cov[2] = sp[0] * sp[0];
        mt = g.mean[0] + 0.13;
        mp = wrap_phi(g.mean[1] + u(-0.03, 0.03));
      }
      if (kind == Case::Seam && j == 0) mp = wrap_phi(kPi - u(0.0, 1.0) * sp[j]);
      if (kind == Case::Border && j == 0) mt = (u() < 0.5 ? -1 : 1) * (kPi / 2 - u(2.5, 3.0) * st[j]);
      const double rho = u(-0.5, 0.5);
      g.weight.push_back(u(0.6, 1.4));
      g.mean.insert(g.mean.end(), {mt, wrap_phi(mp)});
      g.cov.insert(g.cov.end(), {st[j] * st[j], rho * st[j] * sp[j], sp[j] * sp[j]});
    }
    if (kind == Case::Overlap) g.cov[4] = 0;  // the pair: axis-aligned, 0.13 rad = 3.25 sigma_theta
    bool separated = std::abs(g.mean[0]) < kPi / 2 - 2.5 * st[0] || kind == Case::Border;
    for (int i = 0; i < k && separated; ++i)
      for (int j = i + 1; j < k && separated; ++j) {
        if (kind == Case::Overlap && i == 0 && j == 1) continue;
        const double dt = (g.mean[2 * i] - g.mean[2 * j]) / (st[i] + st[j]);
        const double dp = wrapped(g.mean[2 * i + 1] - g.mean[2 * j + 1]) / (sp[i] + sp[j]);
        separated = dt * dt + dp * dp >= 9.0;
      }
    for (int j = 0; j < k && separated; ++j)
      if (!(kind == Case::Border && j == 0)) separated = std::abs(g.mean[2 * j]) <= kPi / 2 - 3.5 * st[j];
    if (!separated && attempt < 10000) continue;
    double sum = 0;
    for (double w : g.weight) sum += w;
    for (double& w : g.weight) w /= sum;
    return out;
  }
}

// The test set: `n` slices of 2 to 6 components, the special cases in turn.
std::vector<Known> known_set(int n, std::uint64_t seed) {
  std::vector<Known> out;
  for (int i = 0; i < n; ++i) {
    const int k = 2 + i % 5;
    const Case kind = static_cast<Case>((i / 5) % 4);
    out.push_back(random_known(k, kind, seed * 1000 + std::uint64_t(i)));
  }
  return out;
}

// A fiber table whose slice t has the integrand weights of known[t] (f = density / cos),
// plus, with `band` > 0, a base uniform in phi of density band * cos(theta)^2 (not a
// mixture of Gaussians: what measured materials have under their lobes).
std::string known_table(const std::string& name, const std::vector<Known>& known, std::size_t nt, std::size_t np,
                        double band = 0.0) {
  TableMeta m = make_grid(Domain::Fiber, known.size(), 1, nt, np, true);
  m.source = R"({"model": "known mixtures"})";
  std::vector<float> v;
  for (const Known& kn : known)
    for (std::size_t i = 0; i < nt; ++i)
      for (std::size_t j = 0; j < np; ++j)
        v.push_back(float((gmm_density(kn.gmm, m.theta_i[i], m.phi_i[j]) +
                           band * std::cos(m.theta_i[i]) * std::cos(m.theta_i[i])) /
                          std::cos(m.theta_i[i])));
  const std::string path = (temp_dir() / name).string();
  write_table(path, m, v);
  return path;
}

FitSettings settings(const std::string& stem, const std::string& search, const std::string& refine = "l1") {
  FitSettings f;
  f.map = "theta_phi";  // the tables are Gaussians in (theta, phi): their true K is known there
  f.output = (temp_dir() / (stem + "_mixture.h5")).string();
  f.report = (temp_dir() / (stem + "_fit.csv")).string();
  f.search_report = (temp_dir() / (stem + "_search.csv")).string();
  f.k_min = 1;
  f.k_max = 10;
  f.restarts = 2;
  f.final_restarts = 2;
  f.iterations = 60;
  f.final_iterations = 150;
  f.tolerance = 1e-7;
  f.search = *search_strategy(search);
  f.refine = refine;
  return f;
}

// The fitted components matched to the true ones (the permutation with the smallest
// sum of squared mean offsets in units of the true standard deviations).
std::vector<int> match(const Gmm& truth, const Gmm& fit) {
  const int k = truth.k();
  std::vector<int> perm(k), best;
  std::iota(perm.begin(), perm.end(), 0);
  double best_cost = 1e300;
  do {
    double c = 0;
    for (int j = 0; j < k; ++j) {
      const int f = perm[j];
      const double dt = (fit.mean[2 * f] - truth.mean[2 * j]) / std::sqrt(truth.cov[3 * j]);
      const double dp = wrapped(fit.mean[2 * f + 1] - truth.mean[2 * j + 1]) / std::sqrt(truth.cov[3 * j + 2]);
      c += dt * dt + dp * dp;
    }
    if (c < best_cost) {
      best_cost = c;
      best = perm;
    }
  } while (std::next_permutation(perm.begin(), perm.end()));
  return best;
}

const char* case_name(Case c) {
  switch (c) {
    case Case::Overlap: return "overlap";
    case Case::Seam: return "seam";
    case Case::Border: return "border";
    default: return "plain";
  }
}

}  // namespace

TEST_CASE("split and merge keep the moments of the mixture", "[search]") {
  Gmm g;
  g.weight = {0.3, 0.7};
  g.mean = {0.2, 3.0, -0.4, -3.1};  // the pair straddles phi = +-pi
  g.cov = {0.02, 0.006, 0.05, 0.01, -0.002, 0.03};
  // Moments of the pair about a point near the seam, phi unwrapped onto one side.
  auto moments = [](const Gmm& m) {
    std::vector<double> r(6, 0.0);
    for (int j = 0; j < m.k(); ++j) {
      const double w = m.weight[j], t = m.mean[2 * j], p = 3.0 + wrapped(m.mean[2 * j + 1] - 3.0);
      r[0] += w;
      r[1] += w * t;
      r[2] += w * p;
      r[3] += w * (m.cov[3 * j] + t * t);
      r[4] += w * (m.cov[3 * j + 1] + t * p);
      r[5] += w * (m.cov[3 * j + 2] + p * p);
    }
    return r;
  };
  const std::vector<double> before = moments(g);
  const Gmm merged = merge_components(g, 0, 1);
  REQUIRE(merged.k() == 1);
  const Gmm split = split_component(merged, 0, 1e-6);
  REQUIRE(split.k() == 2);
  for (const Gmm* m : {&merged, &split}) {
    const std::vector<double> after = moments(*m);
    for (int q = 0; q < 6; ++q) CHECK(after[q] == Approx(before[q]).margin(1e-12));
  }
  // The halves sit on the principal axis, one standard deviation apart.
  const double lambda = 0.5 * (merged.cov[0] + merged.cov[2]) +
                        std::sqrt(0.25 * std::pow(merged.cov[0] - merged.cov[2], 2) + merged.cov[1] * merged.cov[1]);
  const double dt = split.mean[2] - split.mean[0], dp = wrapped(split.mean[3] - split.mean[1]);
  CHECK(std::sqrt(dt * dt + dp * dp) == Approx(std::sqrt(lambda)).epsilon(1e-9));
  // Growing splits the worst-scoring component first.
  ComponentScores scores;
  scores.split = {0.1, 0.5};
  scores.axis = {0, 0};
  const Gmm grown = grow_mixture(g, scores, 3, 1e-6);
  REQUIRE(grown.k() == 3);
  CHECK(grown.weight[0] == Approx(0.3));
  CHECK(grown.weight[1] == Approx(0.35));
}

TEST_CASE("the split score finds the component that covers two lobes; the merge score the pair on one lobe",
          "[search]") {
  const SliceGrid grid = make_slice_grid(Domain::Fiber, 60, 120);
  Gmm truth;
  truth.weight = {0.25, 0.25, 0.5};
  truth.mean = {-0.5, 1.0, -0.2, 1.0, 0.6, -1.5};
  truth.cov = {0.004, 0, 0.02, 0.004, 0, 0.02, 0.02, 0, 0.1};
  const std::vector<double> w = mixture_weights(grid, truth);
  // A fit with one component over the first two lobes and two on the third.
  Gmm fit;
  fit.weight = {0.5, 0.25, 0.25};
  fit.mean = {-0.35, 1.0, 0.5, -1.5, 0.7, -1.5};
  fit.cov = {0.03, 0, 0.02, 0.02, 0, 0.1, 0.02, 0, 0.1};
  const ComponentScores sc = score_components(grid, w, fit, 3);
  CHECK(sc.split[0] > sc.split[1]);
  CHECK(sc.split[0] > sc.split[2]);
  REQUIRE(!sc.merge.empty());
  CHECK(sc.merge[0] == std::make_pair(1, 2));
  // The move merges the pair and splits the wide component: the truth's layout.
  const std::vector<Gmm> moves = smem_candidates(fit, sc, 1, 1e-5);
  REQUIRE(moves.size() == 1);
  const Gmm& m = moves[0];
  REQUIRE(m.k() == 3);
  std::vector<double> thetas;
  for (int j = 0; j < 3; ++j) thetas.push_back(m.mean[2 * j]);
  std::sort(thetas.begin(), thetas.end());
  CHECK(thetas[0] < -0.35);
  CHECK(thetas[1] > -0.35);
  CHECK(thetas[1] < 0.0);
  CHECK(thetas[2] == Approx(0.6).margin(0.11));
}

TEST_CASE("split-and-merge fits at a fixed K are never worse than plain EM from the same start", "[search]") {
  const std::vector<Known> known = known_set(20, 7);
  SliceSet set;
  set.grid = make_slice_grid(Domain::Fiber, 60, 120);
  std::vector<EmTask> tasks;
  for (std::size_t s = 0; s < known.size(); ++s) {
    set.weights.push_back(mixture_weights(set.grid, known[s].gmm));
    EmTask t;
    t.slice = s;
    t.k = known[s].gmm.k();
    t.settings.iterations = 60;
    t.settings.tolerance = 1e-7;
    t.settings.restarts = 1;
    t.settings.seed = 3;
    tasks.push_back(t);
  }
  EmEngine engine(select_devices(""));
  const EmFitter fitter = [&](const SliceSet& ss, const std::vector<EmTask>& t) { return engine.fit(ss, t); };
  const std::vector<EmResult> plain = fitter(set, tasks);
  std::vector<int> accepted;
  const std::vector<EmResult> smem = split_merge_fit(fitter, set, tasks, SmemSettings{}, &accepted);
  REQUIRE(plain.size() == smem.size());
  int improved = 0;
  for (std::size_t i = 0; i < plain.size(); ++i) {
    INFO("slice " << i << " K " << tasks[i].k << ": plain " << plain[i].loglik << ", split-and-merge " << smem[i].loglik);
    REQUIRE(plain[i].ok);
    REQUIRE(smem[i].ok);
    CHECK(smem[i].loglik >= plain[i].loglik);
    if (accepted[i] > 0) CHECK(smem[i].loglik > plain[i].loglik);
    if (smem[i].loglik > plain[i].loglik + 1e-3) ++improved;
  }
  // Some of these starts are local optima that the moves escape.
  CHECK(improved >= 1);
  // The CPU reference takes the same explicit starts.
  std::vector<EmTask> from_fit = {tasks[0]};
  from_fit[0].init = smem[0].gmm;
  const std::vector<EmResult> ref = em_fit_reference(set, from_fit);
  REQUIRE(ref[0].ok);
  CHECK(ref[0].loglik == Approx(smem[0].loglik).epsilon(1e-4));
  // An explicit start with the wrong K is a configuration error.
  from_fit[0].k = tasks[0].k + 1;
  CHECK_THROWS_AS(em_fit_reference(set, from_fit), ConfigError);
  CHECK_THROWS_AS(engine.fit(set, from_fit), ConfigError);
}

TEST_CASE("the search finds the true K of known mixtures and their parameters", "[search]") {
  // Three draws of 40 slices.
  std::vector<Known> known;
  for (std::uint64_t seed : {1, 2, 3}) {
    const std::vector<Known> k = known_set(40, seed);
    known.insert(known.end(), k.begin(), k.end());
  }
  const std::string table = known_table("known.h5", known, 90, 180);
  const FitSettings f = settings("known", "smem");
  const SweepSummary sum = run_sweep(table, f, "");
  REQUIRE(sum.slices == known.size());
  const MixtureFile m = read_mixture_file(f.output);
  REQUIRE(m.slices() == known.size());
  int right = 0;
  std::ostringstream misses;
  for (std::size_t s = 0; s < known.size(); ++s) {
    const Gmm& truth = known[s].gmm;
    Gmm fit;
    m.slice_params(s, fit.weight, fit.mean, fit.cov);
    if (fit.k() != truth.k()) {
      misses << " slice " << s << " (" << case_name(known[s].kind) << ") K " << fit.k() << " not " << truth.k() << ";";
      continue;
    }
    ++right;
    const std::vector<int> perm = match(truth, fit);
    for (int j = 0; j < truth.k(); ++j) {
      const int q = perm[j];
      const double stt = std::sqrt(truth.cov[3 * j]), spp = std::sqrt(truth.cov[3 * j + 2]);
      INFO("slice " << s << " (" << case_name(known[s].kind) << ") component " << j << " of " << truth.k()
                    << ": weight " << fit.weight[q] << " vs " << truth.weight[j] << ", mean (" << fit.mean[2 * q]
                    << ", " << fit.mean[2 * q + 1] << ") vs (" << truth.mean[2 * j] << ", " << truth.mean[2 * j + 1]
                    << "), cov (" << fit.cov[3 * q] << ", " << fit.cov[3 * q + 1] << ", " << fit.cov[3 * q + 2]
                    << ") vs (" << truth.cov[3 * j] << ", " << truth.cov[3 * j + 1] << ", " << truth.cov[3 * j + 2]
                    << ")");
      CHECK(std::abs(fit.weight[q] - truth.weight[j]) <= 0.01 + 0.05 * truth.weight[j]);
      CHECK(std::abs(fit.mean[2 * q] - truth.mean[2 * j]) <= 0.1 * stt);
      CHECK(std::abs(wrapped(fit.mean[2 * q + 1] - truth.mean[2 * j + 1])) <= 0.1 * spp);
      // Covariance: relative error of each entry against the scale of its row and column.
      CHECK(std::abs(fit.cov[3 * q] - truth.cov[3 * j]) <= 0.1 * stt * stt);
      CHECK(std::abs(fit.cov[3 * q + 1] - truth.cov[3 * j + 1]) <= 0.1 * stt * spp);
      CHECK(std::abs(fit.cov[3 * q + 2] - truth.cov[3 * j + 2]) <= 0.1 * spp * spp);
    }
  }
  std::printf("true K on %d of %zu known-mixture slices;%s\n", right, known.size(), misses.str().c_str());
  INFO("true K on " << right << " of " << known.size() << " slices; misses:" << misses.str());
  CHECK(right == int(known.size()));  // docs/fitting.md: every one
}

TEST_CASE("the L1 refinement lowers the error on slices that are not mixtures, never a slice's score", "[search]") {
  std::vector<Known> known;
  for (int i = 0; i < 8; ++i) known.push_back(random_known(2 + i % 3, Case::Plain, 9000 + std::uint64_t(i)));
  const std::string table = known_table("banded.h5", known, 90, 180, 0.05);
  const FitSettings none = settings("banded_none", "smem", "none"), l1 = settings("banded_l1", "smem", "l1");
  run_sweep(table, none, "");
  run_sweep(table, l1, "");
  const MixtureFile a = read_mixture_file(none.output), b = read_mixture_file(l1.output);
  REQUIRE(a.slices() == known.size());
  REQUIRE(b.slices() == known.size());
  for (std::size_t s = 0; s < known.size(); ++s) {
    const double score_a = a.l1_rel[s] + none.k_penalty * a.k[s], score_b = b.l1_rel[s] + l1.k_penalty * b.k[s];
    INFO("slice " << s << ": refine none K " << a.k[s] << " l1 " << a.l1_rel[s] << ", refine l1 K " << b.k[s]
                  << " l1 " << b.l1_rel[s]);
    CHECK(score_b <= score_a + 1e-9);
  }
  // At a pinned K, the refined fits misplace at least 10% less energy in total.
  FitSettings pinned_none = settings("banded_k5_none", "smem", "none"), pinned_l1 = settings("banded_k5_l1", "smem", "l1");
  for (FitSettings* f : {&pinned_none, &pinned_l1}) {
    f->k_min = f->k_max = 5;
    run_sweep(table, *f, "");
  }
  const MixtureFile pa = read_mixture_file(pinned_none.output), pb = read_mixture_file(pinned_l1.output);
  double sum_a = 0, sum_b = 0;
  for (std::size_t s = 0; s < known.size(); ++s) {
    REQUIRE(pa.k[s] == 5);
    REQUIRE(pb.k[s] == 5);
    CHECK(pb.l1_rel[s] <= pa.l1_rel[s]);
    sum_a += pa.l1_rel[s];
    sum_b += pb.l1_rel[s];
  }
  INFO("K = 5: summed l1 " << sum_a << " without, " << sum_b << " with the refinement");
  CHECK(sum_b < 0.9 * sum_a);
  // The key: l1 by default, none, nothing else.
  const fs::path cfg_table = temp_dir() / "config.h5";
  if (!fs::exists(cfg_table))
    write_table(cfg_table.string(), make_grid(Domain::Fiber, 2, 1, 2, 4, true), std::vector<float>(16, 1.0f));
  const std::string head = "table: " + cfg_table.string() + "\nfit:\n";
  CHECK(parse_config(head, "cfg.yaml").fit->refine == "l1");
  CHECK(parse_config(head + "  refine: none\n", "cfg.yaml").fit->refine == "none");
  CHECK_THROWS_WITH(parse_config(head + "  refine: lbfgs\n", "cfg.yaml"), Catch::Contains("refine"));
  CHECK_THROWS_AS(parse_config(head + "  refine_evaluations: 0\n", "cfg.yaml"), ConfigError);
}

TEST_CASE("the search method is a fit key: smem by default, restarts, nothing else", "[search]") {
  const fs::path table = temp_dir() / "config.h5";
  if (!fs::exists(table)) write_table(table.string(), make_grid(Domain::Fiber, 2, 1, 2, 4, true), std::vector<float>(16, 1.0f));
  const std::string head = "table: " + table.string() + "\nfit:\n";
  CHECK(parse_config(head, "cfg.yaml").fit->search == SearchStrategy::Smem);
  CHECK(parse_config(head + "  search: restarts\n", "cfg.yaml").fit->search == SearchStrategy::Restarts);
  CHECK_THROWS_AS(parse_config(head + "  search: kmeans\n", "cfg.yaml"), ConfigError);
}

// A measurement (hidden: run it by its tag): lobes c standard deviations inside the theta
// border, fitted by both search methods, the walk with and without the L1 refinement. With
// BSDFMIX_MEASURE_CSV set it also writes its rows there (bench/reproduce.sh theta_border:
// bench/results/theta_border.csv, the table of docs/studies/theta_border.md).
TEST_CASE("measure: lobes near the theta border", "[.measure]") {
  const std::vector<double> cs = {0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0};
  std::vector<Known> known;
  for (double c : cs)
    for (int rep = 0; rep < 4; ++rep) {
      Known kn = random_known(3, Case::Plain, 500 + std::uint64_t(rep));
      kn.gmm.mean[0] = (rep % 2 ? 1 : -1) * (kPi / 2 - c * std::sqrt(kn.gmm.cov[0]));
      known.push_back(kn);
    }
  const std::string table = known_table("border.h5", known, 90, 180);
  const SliceGrid grid = make_slice_grid(Domain::Fiber, 90, 180);
  const std::vector<std::pair<std::string, std::string>> methods = {
      {"restarts", "none"}, {"smem", "none"}, {"smem", "l1"}};
  std::ostringstream csv;
  csv << "search,refine,c,draw,k,true_k,l1_rel,true_l1_rel,mean_shift_sigma,sigma_ratio\n";
  for (const auto& [method, refine] : methods) {
    const FitSettings f = settings("border_" + method + "_" + refine, method, refine);
    run_sweep(table, f, "");
    const MixtureFile m = read_mixture_file(f.output);
    REQUIRE(m.slices() == known.size());
    for (std::size_t s = 0; s < known.size(); ++s) {
      const Gmm& truth = known[s].gmm;
      WeightedSlice ws;
      ws.theta = grid.theta;
      ws.phi = grid.phi;
      ws.w = mixture_weights(grid, truth);
      const double truth_l1 = l1_rel_error(ws, make_slice_mixture(truth.weight, truth.mean, truth.cov));
      Gmm fit;
      m.slice_params(s, fit.weight, fit.mean, fit.cov);
      std::string shape = "-", shape_csv = ",";
      if (fit.k() == truth.k()) {
        const int q = match(truth, fit)[0];
        const double sd = std::sqrt(truth.cov[0]);
        const double shift = std::abs(fit.mean[2 * q] - truth.mean[0]) / sd, ratio = std::sqrt(fit.cov[3 * q] / truth.cov[0]);
        std::ostringstream o, oc;
        o << "mean shift " << shift << " sigma, sigma ratio " << ratio;
        oc << shift << "," << ratio;
        shape = o.str();
        shape_csv = oc.str();
      }
      csv << method << "," << refine << "," << cs[s / 4] << "," << s % 4 << "," << fit.k() << "," << truth.k() << ","
          << m.l1_rel[s] << "," << truth_l1 << "," << shape_csv << "\n";
      std::printf("%-8s %-4s c %.1f draw %zu: K %d, l1_rel %.4f, true mixture's l1_rel %.4f, %s\n", method.c_str(),
                  refine.c_str(), cs[s / 4], s % 4,
                  fit.k(), m.l1_rel[s], truth_l1, shape.c_str());
      if (cs[s / 4] >= 2.0) CHECK(fit.k() == truth.k());
    }
  }
  if (const char* path = std::getenv("BSDFMIX_MEASURE_CSV")) write_text_atomic(path, csv.str());
}

TEST_CASE("seeding at the residual puts a component on the sharp peak a mixture misses", "[search]") {
  const SliceGrid grid = make_slice_grid(Domain::Hemisphere, 90, 180);
  Gmm base;  // a broad lobe
  base.weight = {1.0};
  base.mean = {0.6, 0.0};
  base.cov = {0.25, 0.0, 0.5};
  const double peak_t = 0.9, peak_p = -1.2, sd = 0.03, share = 0.2;
  Gmm truth = base;
  truth.weight = {1 - share, share};
  for (double x : {peak_t, peak_p}) truth.mean.push_back(x);
  for (double x : {sd * sd, 0.0, sd * sd}) truth.cov.push_back(x);
  const std::size_t np = grid.phi.size();
  std::vector<double> w(grid.cells());
  for (std::size_t i = 0; i < w.size(); ++i) w[i] = gmm_density(truth, grid.theta[i / np], grid.phi[i % np]);
  const Gmm seeded = seed_at_residual(grid, w, base, 2, 1e-6);
  REQUIRE(seeded.k() == 2);
  const double dt = grid.theta[1] - grid.theta[0], dp = grid.phi[1] - grid.phi[0];
  CHECK(std::abs(seeded.mean[2] - peak_t) < dt);
  CHECK(std::abs(seeded.mean[3] - peak_p) < dp);
  CHECK(std::sqrt(seeded.cov[3]) == Approx(sd).epsilon(0.5));
  CHECK(seeded.weight[1] == Approx(share).epsilon(0.3));
  CHECK(seeded.weight[0] + seeded.weight[1] == Approx(1.0));
  // nothing left to seed: the mixture comes back as it is
  CHECK(seed_at_residual(grid, w, truth, 2, 1e-6).k() == 2);
}

// bench/hard_table.py's shape (CHANGELOG.md, "A walk that does not give up"): a sharp
// peak 30x a broad base, with fringes. Before the walk restarted from its best fit and
// seeded at the residual, it stopped at K = 5 and 6 on these two slices, at 17.5% and
// 19.7% L1, where a fit pinned at K = 8 or 16 reaches 8.5% and 7.3%.
TEST_CASE("a walk that stalls still reaches the score of the best pinned fit", "[search]") {
  TableMeta m = make_grid(Domain::Hemisphere, 12, 1, 90, 180, true);
  std::vector<float> v;
  for (double t0 : m.theta_o)
    for (double t : m.theta_i)
      for (double p : m.phi_i) {
        const double c = std::sin(t) * std::sin(t0) * std::cos(p) + std::cos(t) * std::cos(t0);
        const double ang = std::acos(std::clamp(c, -1.0, 1.0));
        const double base = std::exp(-ang * ang / (2 * 0.25)) + 0.3, fringes = 1 + 0.35 * std::sin(ang / 0.09);
        v.push_back(float(0.1 * (base * fringes + 30.0 * std::exp(-ang * ang / (2 * 0.035 * 0.035)))));
      }
  const std::string table = (temp_dir() / "stall.h5").string();
  write_table(table, m, v);
  auto fit_at = [&](const std::string& stem, int k_min, int k_max) {
    FitSettings f;
    f.output = (temp_dir() / (stem + "_mixture.h5")).string();
    f.report = (temp_dir() / (stem + "_fit.csv")).string();
    f.search_report = (temp_dir() / (stem + "_search.csv")).string();
    f.k_min = k_min;
    f.k_max = k_max;
    f.theta_o = {m.theta_o[3], m.theta_o[10]};
    run_sweep(table, f, "");
    return read_mixture_file(f.output);
  };
  const MixtureFile walk = fit_at("stall_walk", 1, 32);
  REQUIRE(walk.slices() == 2);
  const double k_penalty = FitSettings{}.k_penalty;
  for (int pinned : {4, 8, 16}) {
    const MixtureFile p = fit_at("stall_k" + std::to_string(pinned), pinned, pinned);
    for (std::size_t s = 0; s < 2; ++s) {
      const double chosen = candidate_score(walk.k[s], walk.l1_rel[s], k_penalty),
                   at_k = candidate_score(pinned, p.l1_rel[s], k_penalty);
      INFO("slice " << s << ": the walk K " << walk.k[s] << " l1 " << walk.l1_rel[s] << ", pinned K " << pinned
                    << " l1 " << p.l1_rel[s]);
      CHECK(chosen <= at_k + 0.01);  // within a point of L1
    }
  }
}

// The sharp colour-shifting film of data/rgl/ at a grazing view (theta_o 85.5 degrees):
// the walk's EM fits get worse past K = 4 (22.8%, then 26.7% and 24.7% at K = 5 and 6),
// the patience ends it, and its best fit still misplaces a fifth of the slice. The final
// fits then weigh a fit two Ks past the last walked, from k-means++ restarts (a fit
// pinned at K = 8 reaches 9%); without it the slice kept K = 5 at 19.6%.
TEST_CASE("a stalled walk with a poor best fit is fitted past its last K, as well as a pinned K", "[search]") {
  RglImportOptions imp;
  imp.file = std::string(BSDFMIX_SOURCE_DIR) + "/data/rgl/cc_iris_purple_gem_rgb.bsdf";
  imp.n_theta_o = 90;
  imp.n_theta_i = 90;
  imp.n_phi_i = 180;
  const std::string table = (temp_dir() / "iris.h5").string();
  import_rgl_table(imp, table);
  FitSettings f;
  f.output = (temp_dir() / "iris_mixture.h5").string();
  f.report = (temp_dir() / "iris_fit.csv").string();
  f.search_report = (temp_dir() / "iris_search.csv").string();
  f.theta_o = {85.5 * 3.14159265358979 / 180};
  f.map = "theta_phi";  // the stall this test pins is that of the (theta, phi) fit
  run_sweep(table, f, "");
  const MixtureFile m = read_mixture_file(f.output);
  REQUIRE(m.slices() == 1);
  const auto rows = test::csv_rows(f.search_report);
  int walked = 0, beyond = 0;
  double best_walk = 1e300;
  for (std::size_t i = 1; i < rows.size(); ++i) {  // slice,k,restart,loglik,l1_rel,score,chosen
    const auto& c = rows[i];
    REQUIRE(c.size() >= 6);
    if (c[2] == "2") beyond = std::stoi(c[1]);
    else walked = std::max(walked, std::stoi(c[1])), best_walk = std::min(best_walk, std::stod(c[5]));
  }
  INFO("walked to K " << walked << ", fitted past it at K " << beyond << "; chosen K " << m.k[0] << " at l1 " << m.l1_rel[0]);
  CHECK(beyond > walked);
  CHECK(candidate_score(m.k[0], m.l1_rel[0], f.k_penalty) <= best_walk);
  CHECK(m.l1_rel[0] < 0.12);

  // At 80.5 degrees the fits past the walk that the split-and-merge round keeps (by the
  // log-likelihood) misplace 17% or more; the same starts without it reach the error of
  // a fit pinned at K = 8.
  f.theta_o = {80.5 * 3.14159265358979 / 180};
  f.output = (temp_dir() / "iris80_mixture.h5").string();
  f.report = (temp_dir() / "iris80_fit.csv").string();
  f.search_report = (temp_dir() / "iris80_search.csv").string();
  run_sweep(table, f, "");
  const MixtureFile walked80 = read_mixture_file(f.output);
  FitSettings pinned = f;
  pinned.output = (temp_dir() / "iris_pinned.h5").string();
  pinned.report = (temp_dir() / "iris_pinned.csv").string();
  pinned.search_report = (temp_dir() / "iris_pinned_search.csv").string();
  pinned.k_min = pinned.k_max = 8;
  run_sweep(table, pinned, "");
  const MixtureFile pinned80 = read_mixture_file(pinned.output);
  const double score = candidate_score(walked80.k[0], walked80.l1_rel[0], f.k_penalty);
  const double pinned_score = candidate_score(pinned80.k[0], pinned80.l1_rel[0], f.k_penalty);
  INFO("80.5 deg: chosen K " << walked80.k[0] << " at l1 " << walked80.l1_rel[0] << "; pinned K 8 at l1 "
                             << pinned80.l1_rel[0]);
  CHECK(score <= pinned_score + 0.005);
  CHECK(walked80.l1_rel[0] < 0.06);
}
