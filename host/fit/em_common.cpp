// EM pieces shared by the engine and the reference: slices, tasks, initialization.
#include <algorithm>
#include <cmath>
#include <limits>

#include "core/error.hpp"
#include "core/hash.hpp"
#include "fit/em_internal.hpp"

namespace bsdfmix {

std::string precision_name(EmPrecision p) {
  switch (p) {
    case EmPrecision::Fp32: return "fp32";
    case EmPrecision::Fp64: return "fp64";
    default: return "auto";
  }
}

EmPrecision parse_precision(const std::string& name) {
  if (name == "auto") return EmPrecision::Auto;
  if (name == "fp32") return EmPrecision::Fp32;
  if (name == "fp64") return EmPrecision::Fp64;
  throw ConfigError("unknown EM precision '" + name + "' (expected auto, fp32 or fp64)");
}

namespace em_detail {

PreparedSlice prepare_slice(const SliceSet& set, std::size_t slice) {
  PreparedSlice p;
  const auto& w = set.weights[slice];
  double total = 0;
  for (double v : w) total += v;
  if (!(total > 0) || !std::isfinite(total)) {
    p.failure = "slice " + std::to_string(slice) + " has zero total weight";
    return p;
  }
  p.w.resize(w.size());
  for (std::size_t i = 0; i < w.size(); ++i) {
    p.w[i] = w[i] / total;
    if (p.w[i] > 0) ++p.positive;
  }
  return p;
}

std::string task_failure(const PreparedSlice& s, std::size_t slice, int k) {
  if (!s.failure.empty()) return s.failure;
  if (s.positive < static_cast<std::size_t>(k))
    return "slice " + std::to_string(slice) + " has " + std::to_string(s.positive) +
           " cells with positive weight, fewer than K = " + std::to_string(k);
  return "";
}

void validate_tasks(const SliceSet& set, const std::vector<EmTask>& tasks) {
  for (std::size_t i = 0; i < tasks.size(); ++i) {
    const EmTask& t = tasks[i];
    const std::string where = "EM task " + std::to_string(i) + ": ";
    if (t.slice >= set.weights.size())
      throw ConfigError(where + "slice " + std::to_string(t.slice) + " out of range (" +
                        std::to_string(set.weights.size()) + " slices)");
    if (t.k < 1 || t.k > kEmMaxK)
      throw ConfigError(where + "K = " + std::to_string(t.k) + " outside 1.." + std::to_string(kEmMaxK));
    if (t.settings.iterations < 1)
      throw ConfigError(where + "iterations must be at least 1");
    if (t.settings.restarts < 1) throw ConfigError(where + "restarts must be at least 1");
    if (!std::isfinite(t.settings.tolerance)) throw ConfigError(where + "tolerance must be finite");
    if (!(t.settings.min_weight >= 0) || !(t.settings.min_weight < 1))
      throw ConfigError(where + "min_weight must be in [0, 1)");
    if (!std::isfinite(t.settings.cov_floor)) throw ConfigError(where + "cov_floor must be finite");
    if (!t.init.weight.empty()) {
      const Gmm& g = t.init;
      if (g.k() != t.k || g.mean.size() != 2 * g.weight.size() || g.cov.size() != 3 * g.weight.size())
        throw ConfigError(where + "the initial mixture must have K = " + std::to_string(t.k) + " components");
      for (int j = 0; j < g.k(); ++j) {
        const double a = g.cov[3 * j], b = g.cov[3 * j + 1], c = g.cov[3 * j + 2];
        if (!(g.weight[j] > 0) || !std::isfinite(g.weight[j]) || !std::isfinite(g.mean[2 * j]) ||
            !std::isfinite(g.mean[2 * j + 1]) || !(a > 0) || !(c > 0) || !std::isfinite(a + b + c) ||
            !(a * c - b * b > 0))
          throw ConfigError(where + "initial component " + std::to_string(j) +
                            " needs a positive weight, finite mean and positive-definite covariance");
      }
    }
  }
}

double cov_floor(const SliceGrid& grid, const EmSettings& s) {
  if (s.cov_floor >= 0) return s.cov_floor;
  const double step = std::min(axis_step(grid.theta), axis_step(grid.phi));
  return 0.0625 * step * step;
}

void floor_covariance(double& a, double& b, double& c, double f) {
  const double half_tr = 0.5 * (a + c);
  const double disc = std::sqrt(0.25 * (a - c) * (a - c) + b * b);
  const double l1 = half_tr + disc, l2 = half_tr - disc;
  if (l2 >= f) return;
  if (b == 0.0) {
    a = std::max(a, f);
    c = std::max(c, f);
    return;
  }
  double vx = l1 - c, vy = b;
  const double n = std::sqrt(vx * vx + vy * vy);
  vx /= n;
  vy /= n;
  const double m1 = std::max(l1, f), m2 = f;
  a = m1 * vx * vx + m2 * vy * vy;
  b = (m1 - m2) * vx * vy;
  c = m1 * vy * vy + m2 * vx * vx;
}

// Largest eigenvalue of [a b; b c] and its unit eigenvector; with minor, the smallest
// and the eigenvector perpendicular.
void principal_axis(double a, double b, double c, double& lambda, double& vx, double& vy, bool minor) {
  const double disc = std::sqrt(0.25 * (a - c) * (a - c) + b * b);
  lambda = 0.5 * (a + c) + disc;
  if (std::abs(b) > 0) {
    vx = lambda - c;
    vy = b;
  } else if (a >= c) {
    vx = 1;
    vy = 0;
  } else {
    vx = 0;
    vy = 1;
  }
  const double n = std::sqrt(vx * vx + vy * vy);
  vx /= n;
  vy /= n;
  if (minor) {
    lambda = std::max(0.5 * (a + c) - disc, 0.0);
    const double t = vx;
    vx = -vy;
    vy = t;
  }
}


int k_bucket(int k) {
  int b = 4;
  while (b < k) b *= 2;
  return b;
}

std::vector<std::pair<int, std::vector<std::size_t>>> bucket_batches(
    const std::map<int, std::vector<std::size_t>>& groups, std::size_t stride, int extra_rows,
    std::uint64_t batch_budget) {
  std::vector<std::pair<int, std::vector<std::size_t>>> batches;
  for (const auto& [bucket, list] : groups) {
    const std::uint64_t per = static_cast<std::uint64_t>(stride) * static_cast<std::uint64_t>(bucket + extra_rows);
    const std::size_t cap = static_cast<std::size_t>(std::max<std::uint64_t>(1, batch_budget / per));
    for (std::size_t b = 0; b < list.size(); b += cap)
      batches.push_back({bucket, std::vector<std::size_t>(list.begin() + b, list.begin() + std::min(list.size(), b + cap))});
  }
  return batches;
}

std::vector<ProblemBatch> plan_batches(const std::vector<std::pair<int, std::vector<std::size_t>>>& groups,
                                       std::size_t stride, int extra_rows, std::uint64_t limit,
                                       std::uint64_t batch_budget) {
  std::vector<ProblemBatch> out;
  for (const auto& [bucket, list] : groups) {
    check_problem_fits(stride, bucket, extra_rows, limit);
    for (auto& [b, items] : bucket_batches({{bucket, list}}, stride, extra_rows, batch_budget))
      out.push_back(ProblemBatch{b, std::move(items)});
  }
  return out;
}

BatchSlices::BatchSlices(std::size_t n, const std::function<std::size_t(std::size_t)>& slice_of) : local(n) {
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t slice = slice_of(i);
    auto it = of_slice.find(slice);
    if (it == of_slice.end()) it = of_slice.emplace(slice, static_cast<int>(of_slice.size())).first;
    local[i] = it->second;
  }
}

void check_query(const std::string& what, std::size_t slice, std::size_t n_slices, int k) {
  if (slice >= n_slices) throw ConfigError(what + ": slice " + std::to_string(slice) + " out of range");
  if (k < 1 || k > kEmMaxK)
    throw ConfigError(what + ": K = " + std::to_string(k) + " outside 1.." + std::to_string(kEmMaxK));
}

bool run_on_device(const BatchRun& run, const Device& device, const std::string& what,
                   const std::function<void()>& work) {
  try {
    work();
  } catch (const cl::Error& e) {
    throw_device_error(e, what + " on " + device.info().label());
  }
  return run.claim();
}

void check_problem_fits(std::size_t stride, int bucket, int extra_rows, std::uint64_t limit) {
  const std::uint64_t per = static_cast<std::uint64_t>(stride) * static_cast<std::uint64_t>(bucket + extra_rows);
  if (per > limit)
    throw DeviceError("a slice of " + std::to_string(stride) + " padded cells at " + std::to_string(bucket) +
                      " components needs " + std::to_string(4 * per) +
                      " bytes in one buffer, more than a selected device allows in one allocation (" +
                      std::to_string(4 * limit) + "); import the table at a lower resolution");
}

void component_constants(const Gmm& gmm, int j, int K, double log2_weight, float* cp) {
  const double a = gmm.cov[3 * j], b = gmm.cov[3 * j + 1], c = gmm.cov[3 * j + 2];
  const double det = a * c - b * b, l2e = 1.4426950408889634;
  cp[0 * K + j] = static_cast<float>(gmm.mean[2 * j]);
  cp[1 * K + j] = static_cast<float>(wrap_phi(gmm.mean[2 * j + 1]));
  cp[2 * K + j] = static_cast<float>(-0.5 * l2e * c / det);
  cp[3 * K + j] = static_cast<float>(l2e * b / det);
  cp[4 * K + j] = static_cast<float>(-0.5 * l2e * a / det);
  cp[5 * K + j] = static_cast<float>(log2_weight - std::log2(2 * kPi) - 0.5 * std::log2(det));
}

namespace {

struct Rng {
  std::uint64_t state;
  double uniform() {  // [0, 1)
    state = splitmix64(state);
    return static_cast<double>(state >> 11) * 0x1.0p-53;
  }
};

// Index i with probability p_i / sum p (p >= 0, sum > 0).
std::size_t sample(const std::vector<double>& p, double total, Rng& rng) {
  const double u = rng.uniform() * total;
  double c = 0;
  std::size_t last = 0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    if (p[i] <= 0) continue;
    c += p[i];
    last = i;
    if (u < c) return i;
  }
  return last;
}

}  // namespace

Gmm initialize(const SliceGrid& grid, const std::vector<double>& w, std::size_t slice, int k,
               int restart, const EmSettings& settings) {
  const std::size_t nt = grid.theta.size(), np = grid.phi.size(), n = nt * np;
  Rng rng{splitmix64(splitmix64(splitmix64(splitmix64(settings.seed) ^ (slice * 0xD6E8FEB86659FD93ULL)) ^
                            (static_cast<std::uint64_t>(k) * 0xA0761D6478BD642FULL)) ^
                   (static_cast<std::uint64_t>(restart) * 0xE7037ED1A0B428DBULL))};
  std::vector<double> ct(k), cp(k);
  std::vector<double> d2(n, std::numeric_limits<double>::infinity()), p(n);
  std::vector<int> assign(n, 0);
  // Cell coordinates, and the nearest-image phi difference of two wrapped angles.
  std::vector<double> xt(n), xp(n);
  for (std::size_t i = 0; i < n; ++i) {
    cell_point(grid, i, xt[i], xp[i]);
    xp[i] = wrap_phi(xp[i]);
  }
  auto wrap_diff = [](double d) { return d > kPi ? d - 2 * kPi : (d < -kPi ? d + 2 * kPi : d); };
  auto add_center = [&](int j, std::size_t cell) {
    ct[j] = xt[cell];
    cp[j] = xp[cell];
    for (std::size_t i = 0; i < n; ++i) {
      const double dt = xt[i] - ct[j];
      const double dp = wrap_diff(xp[i] - cp[j]);
      const double d = dt * dt + dp * dp;
      if (d < d2[i]) {
        d2[i] = d;
        assign[i] = j;
      }
    }
  };
  double total = 0;
  for (double v : w) total += v;
  add_center(0, sample(w, total, rng));
  for (int j = 1; j < k; ++j) {
    double t = 0;
    for (std::size_t i = 0; i < n; ++i) t += (p[i] = w[i] * d2[i]);
    if (t > 0) {
      add_center(j, sample(p, t, rng));
    } else {  // every weighted cell is a center already: the heaviest non-center cell
      std::size_t best = n;
      for (std::size_t i = 0; i < n; ++i)
        if (d2[i] > 0 && (best == n || w[i] > w[best])) best = i;
      add_center(j, best == n ? 0 : best);
    }
  }
  // One hard-assignment pass.
  std::vector<double> s(6 * static_cast<std::size_t>(k), 0.0);
  for (std::size_t i = 0; i < n; ++i) {
    if (w[i] <= 0) continue;
    const int j = assign[i];
    const double dt = xt[i] - ct[j];
    const double dp = wrap_diff(xp[i] - cp[j]);
    double* a = &s[6 * j];
    a[0] += w[i];
    a[1] += w[i] * dt;
    a[2] += w[i] * dp;
    a[3] += w[i] * dt * dt;
    a[4] += w[i] * dt * dp;
    a[5] += w[i] * dp * dp;
  }
  const double floor = cov_floor(grid, settings);
  Gmm g;
  g.weight.resize(k);
  g.mean.resize(2 * k);
  g.cov.resize(3 * k);
  double wsum = 0;
  for (int j = 0; j < k; ++j) {
    const double* a = &s[6 * j];
    const double m = std::max(a[0], std::numeric_limits<double>::min());
    const double dt = a[1] / m, dp = a[2] / m;
    g.weight[j] = a[0];
    wsum += a[0];
    g.mean[2 * j] = ct[j] + dt;
    g.mean[2 * j + 1] = wrap_phi(cp[j] + dp);
    double stt = std::max(a[3] / m - dt * dt, 0.0), spp = std::max(a[5] / m - dp * dp, 0.0);
    double stp = a[4] / m - dt * dp;
    const double lim = std::sqrt(stt * spp);
    stp = std::min(std::max(stp, -lim), lim);
    floor_covariance(stt, stp, spp, floor);
    g.cov[3 * j] = stt;
    g.cov[3 * j + 1] = stp;
    g.cov[3 * j + 2] = spp;
  }
  for (int j = 0; j < k; ++j) g.weight[j] = wsum > 0 ? g.weight[j] / wsum : 1.0 / k;
  return g;
}

Gmm task_start(const SliceGrid& grid, const std::vector<double>& w, const EmTask& task, int restart) {
  if (restart == 0 && !task.init.weight.empty()) {
    Gmm g = task.init;
    double sum = 0;
    for (double x : g.weight) sum += x;
    for (double& x : g.weight) x /= sum;
    for (int j = 0; j < g.k(); ++j) g.mean[2 * j + 1] = wrap_phi(g.mean[2 * j + 1]);
    return g;
  }
  return initialize(grid, w, task.slice, task.k, restart, task.settings);
}

double weighted_loglik(const SliceGrid& grid, const std::vector<double>& w, const Gmm& gmm) {
  // The cells of positive weight, their log densities at once (gmm_log_densities).
  std::vector<double> x, y, ld;
  std::vector<std::size_t> cells;
  for (std::size_t i = 0; i < w.size(); ++i) {
    if (!(w[i] > 0)) continue;
    double a, b;
    cell_point(grid, i, a, b);
    x.push_back(a);
    y.push_back(b);
    cells.push_back(i);
  }
  ld.resize(cells.size());
  gmm_log_densities(gmm, x.data(), y.data(), cells.size(), ld.data());
  double l = 0;
  for (std::size_t c = 0; c < cells.size(); ++c) l += w[cells[c]] * ld[c];
  return l;
}

}  // namespace em_detail
}  // namespace bsdfmix
