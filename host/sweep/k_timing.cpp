// Fit time and fit error against K for chosen slices.
#include "sweep/k_timing.hpp"

#include <chrono>
#include <cstdio>
#include <sstream>

#include "core/atomic_file.hpp"
#include "core/progress.hpp"
#include "fit/em.hpp"
#include "io/table.hpp"
#include "sweep/criterion.hpp"
#include "sweep/fit_error.hpp"

namespace bsdfmix {

std::vector<KTimingRow> time_k(const std::string& table_path, const FitSection& fit, const std::string& device_selector,
                               const std::vector<std::size_t>& slices, const std::vector<std::string>& types) {
  TableReader reader(table_path);
  const TableMeta& meta = reader.meta();
  EmEngine engine(select_devices(device_selector));
  const std::vector<int> ks = candidate_ks(fit.k_min, fit.k_max);
  std::vector<KTimingRow> rows;
  Progress progress("time K on " + table_path, slices.size() * ks.size(), "fits");
  for (std::size_t i = 0; i < slices.size(); ++i) {
    const std::size_t s = slices[i];
    const std::size_t t_o = s / meta.phi_o.size(), p_o = s % meta.phi_o.size();
    const auto f = reader.read_slice(t_o, p_o);
    WeightedSlice ws{meta.theta_i, meta.phi_i, integrand_weights(meta.domain, meta.theta_i, meta.phi_i, f.data())};
    SliceSet set;
    set.grid.domain = meta.domain;
    set.grid.theta = meta.theta_i;
    set.grid.phi = meta.phi_i;
    set.weights.push_back(ws.w);
    for (int k : ks) {
      EmTask task;
      task.slice = 0;
      task.k = k;
      task.settings.iterations = fit.final_iterations;
      task.settings.tolerance = fit.tolerance;
      task.settings.restarts = fit.final_restarts;
      task.settings.seed = fit.seed + s;
      const auto t0 = std::chrono::steady_clock::now();
      const EmResult r = engine.fit(set, {task}).front();
      KTimingRow row;
      row.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      row.slice = s;
      row.type = i < types.size() ? types[i] : "slice";
      row.theta_o = meta.theta_o[t_o];
      row.k = k;
      row.iterations = r.iterations;
      row.l1_rel = r.ok ? l1_rel_error(ws, make_slice_mixture(r.gmm.weight, r.gmm.mean, r.gmm.cov)) : 2.0;
      rows.push_back(row);
      progress.advance();
    }
  }
  progress.finish();
  return rows;
}

void write_k_timing_csv(const std::string& path, const std::vector<KTimingRow>& rows) {
  std::ostringstream s;
  s << "slice,type,theta_o,k,seconds,iterations,l1_rel\n";
  char buf[256];
  for (const auto& r : rows) {
    std::snprintf(buf, sizeof buf, "%zu,%s,%.9g,%d,%.6f,%d,%.9g\n", r.slice, r.type.c_str(), r.theta_o, r.k, r.seconds,
                  r.iterations, r.l1_rel);
    s << buf;
  }
  write_text_atomic(path, s.str());
}

}  // namespace bsdfmix
