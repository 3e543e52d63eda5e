// The convergence study driver.
#include "converge/study.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <limits>
#include <map>
#include <memory>
#include <sstream>

#include "scene/light_mixture.hpp"
#include "converge/quadrature.hpp"
#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "core/format.hpp"
#include "core/progress.hpp"
#include "io/mixture_file.hpp"
#include "sweep/map_choice.hpp"
#include "tables/rgl_brdf.hpp"

namespace bsdfmix {

namespace {

std::string num(double x) { return format_number(x, "%.9g"); }

// Three significant digits.
std::string short_num(double x) { return format_number(x, "%.3g"); }

std::string fixed(double x, int digits) { return format_number(x, ("%." + std::to_string(digits) + "f").c_str()); }

// The "sha256" of a table's source (JSON text, as the RGL importer writes it); "" if none.
std::string source_sha256(const std::string& json) {
  const std::string key = "\"sha256\"";
  const std::size_t k = json.find(key);
  if (k == std::string::npos) return "";
  const std::size_t colon = json.find(':', k + key.size());
  const std::size_t a = colon == std::string::npos ? colon : json.find('"', colon);
  const std::size_t b = a == std::string::npos ? a : json.find('"', a + 1);
  return b == std::string::npos ? "" : json.substr(a + 1, b - a - 1);
}

// is_rgl and mis_light_rgl: the RGL file, checked against the table it must have made.
std::unique_ptr<RglBrdf> load_rgl(const StudySpec& spec, const TableReader& table) {
  if (spec.rgl.empty())
    throw ConfigError("converge.rgl: is_rgl and mis_light_rgl sample with an RGL file's own warps: name the .bsdf "
                      "file the table was imported from (or import the table in this config, import.rgl)");
  if (table.meta().domain != Domain::Hemisphere)
    throw InputError(spec.table + ": is_rgl and mis_light_rgl need a hemisphere table imported from an RGL file");
  for (const auto& d : spec.directions)
    if (!(d.first >= 0 && d.first < kPi / 2))
      throw ConfigError("converge.theta_o: is_rgl and mis_light_rgl need view elevations in [0, pi/2), not " +
                        num(d.first));
  auto rgl = std::make_unique<RglBrdf>(spec.rgl);
  const std::string want = source_sha256(table.meta().source);
  if (want.empty())
    throw InputError(spec.table + ": not imported from an RGL file (its source names no sha256), so " + spec.rgl +
                     " cannot sample it (is_rgl, mis_light_rgl)");
  if (want != rgl->sha256())
    throw InputError(spec.rgl + ": sha256 " + rgl->sha256() + " differs from that of the file " + spec.table +
                     " was imported from (" + want + ")");
  return rgl;
}

}  // namespace

std::vector<ConvergenceRow> convergence_rows(const RunSums& sums, double reference, double ns_per_sample) {
  std::vector<ConvergenceRow> rows;
  for (int l = 0; l < sums.levels; ++l) {
    const double N = std::ldexp(1.0, l);
    double mean = 0, se = 0;
    for (int r = 0; r < sums.runs; ++r) {
      const double est = sums.at(r, l) / N;
      mean += est;
      se += (est - reference) * (est - reference);
    }
    ConvergenceRow row;
    row.samples = std::uint64_t(N);
    row.runs = sums.runs;
    row.mean = mean / sums.runs;
    row.reference = reference;
    row.rmse = std::sqrt(se / sums.runs);
    row.rel_rmse = reference != 0 ? row.rmse / std::abs(reference) : std::numeric_limits<double>::infinity();
    row.ns_per_sample = ns_per_sample;
    rows.push_back(row);
  }
  return rows;
}

std::string format_row(const ConvergenceRow& r) {
  return r.table + "," + num(r.theta_o) + "," + num(r.phi_o) + "," + r.scene + "," + r.estimator + "," +
         std::to_string(r.samples) + "," + std::to_string(r.runs) + "," + num(r.mean) + "," + num(r.reference) + "," +
         num(r.rmse) + "," + num(r.rel_rmse) + "," + num(r.ns_per_sample) + "," + num(r.uniform_fraction);
}

namespace {

// What the study reads once: the table, its mixtures, the devices, the RGL file and the
// lighting mixtures (one per scene) of the estimators that need them.
struct StudyInputs {
  explicit StudyInputs(const StudySpec& spec) : table(spec.table), mf(read_mixture_file(spec.mixture)) {}
  TableReader table;
  MixtureFile mf;
  mix::MixtureSet set;
  std::vector<Device> devices;
  std::unique_ptr<RglBrdf> rgl;
  bool product = false;
  std::vector<LightMixture> light_mix;
  std::vector<Estimator> table_estimators;  // the light tail's columns
};

bool any_estimator(const StudySpec& spec, bool (*pred)(Estimator)) {
  return std::any_of(spec.estimators.begin(), spec.estimators.end(), pred);
}

void read_inputs(const StudySpec& spec, StudyInputs& in) {
  if (in.mf.domain != in.table.meta().domain)
    throw InputError(spec.mixture + ": domain " + domain_name(in.mf.domain) + " differs from the table's (" +
                     spec.table + ": " + domain_name(in.table.meta().domain) + ")");
  in.set = to_mixture_set(in.mf);
  if (!spec.cpu) in.devices = select_devices(spec.device);
  const std::string where = spec.cpu ? std::string("CPU reference") : in.devices.front().info().label();
  if (any_estimator(spec, rgl_estimator)) in.rgl = load_rgl(spec, in.table);
  log_line("converge: " + spec.table + " with " + spec.mixture + " on " + where + ": " +
           std::to_string(spec.directions.size()) + " directions x " + std::to_string(spec.scenes.size()) +
           " scenes x " + std::to_string(spec.estimators.size()) + " estimators, " + std::to_string(spec.runs) +
           " runs of up to " + std::to_string(spec.samples_max) + " samples (seed " + std::to_string(spec.seed) + ")");
  if (!spec.cpu && any_estimator(spec, [](Estimator e) { return !on_device(e); }))
    log_line("converge: the estimators without a kernel (is_rgl, mis_light_rgl: the RGL file's warps; registered "
             "ones) run on the CPU reference, and their ns_per_sample is that one CPU launch's (no timing rounds), "
             "not comparable with the device's");
  // The lighting mixtures, one per scene, for the product estimators.
  in.product = any_estimator(spec, uses_product);
  in.light_mix.resize(spec.scenes.size());
  FitSettings light_fit = spec.light_fit;  // the lighting in the mixtures' own map: the product needs one plane
  light_fit.map = map_setting(in.set.map);
  if (in.product)
    for (std::size_t s = 0; s < spec.scenes.size(); ++s) {
      Lighting l = spec.scenes[s];
      l.domain = in.table.meta().domain;
      const std::string cache = spec.light_cache_dir.empty()
                                    ? (std::filesystem::path(spec.csv).parent_path() / "light_mixtures").string()
                                    : spec.light_cache_dir;
      in.light_mix[s] = lighting_mixture(l, in.table.meta(), light_fit, cache, spec.device, spec.light_engine);
      const LightMixture& m = in.light_mix[s];
      log_line("converge: lighting '" + l.name + "': K " + std::to_string(m.k) + ", L1 " + short_num(m.l1_rel) +
               (m.cached ? ", read from " + m.path + " (its fit took " + fixed(m.fit_seconds, 1) + " s)"
                          : ", fitted in " + fixed(m.fit_seconds, 1) + " s (" + m.path + ")"));
    }
  for (const Estimator e : spec.estimators)
    if (uses_table(e)) in.table_estimators.push_back(e);
}

// The tail diagnostic of one direction, scene-independent (L_i = 1): its CSV row, and its
// line in the log.
std::string direction_tail(const StudySpec& spec, const StudyInputs& in, double theta_o, double phi_o) {
  const TableReader& table = in.table;
  const MixtureFile& mf = in.mf;
  MisOptions mis;  // mis_tab's share alone matters here
  mis.uniform_fraction = spec.mis.uniform_fraction;
  mis.earned = spec.mis.earned;
  Problem p0 = make_problem(table, in.set, theta_o, phi_o, default_lighting(table.meta().domain, 1.0), mis, nullptr);
  const TailDiagnostic td = tail_diagnostic(p0);
  const auto b = in.set.blend(theta_o, phi_o);
  int main = 0;  // the slice with the largest blend weight
  for (int k = 1; k < b.count; ++k)
    if (b.weight[k] > b.weight[main]) main = k;
  const int main_slice = b.slice[main];
  const int k_used = mf.k[std::size_t(main_slice)];
  const double l1 = mf.l1_rel[std::size_t(main_slice)];
  // One table slice as stored, float32: the luminance, and R, G, B where the table has
  // them (the mixture's share below holds its rgb_scale too).
  const std::uint64_t table_bytes = table.meta().cells_per_slice() * sizeof(float) * (table.meta().rgb ? 4 : 1);
  // The slice's share of the mixture file's datasets: its padded row and its scalars.
  const std::uint64_t mix_bytes = mf.payload_bytes() / std::max<std::uint64_t>(mf.slices(), 1);
  const std::string row = spec.table_label + "," + num(theta_o) + "," + num(phi_o) + "," + std::to_string(k_used) +
                          "," + num(l1) + "," + num(td.reference) + "," + num(td.stand_in) + "," +
                          num(td.stand_in / td.reference - 1) + "," + num(td.relvar_us) + "," + num(td.relvar_is) +
                          "," + num(td.relvar_mis) + "," + num(td.max_weight_is) + "," + num(td.max_weight_mis) + "," +
                          std::to_string(table_bytes) + "," + std::to_string(mix_bytes) + "," + num(td.missed_is) +
                          "\n";
  std::string msg = "converge: theta_o " + fixed(theta_o, 4) + " phi_o " + fixed(phi_o, 4) + ": K " +
                    std::to_string(k_used) + ", mis_tab uniform share " + short_num(p0.mis.uniform_fraction) +
                    (spec.mis.earned ? " (earned)" : "") + ", predicted variance per sample (L=1) " +
                    (td.relvar_us > 1e-9 ? "relative to uniform: is_tab " + num(td.relvar_is / td.relvar_us) +
                                               ", mis_tab " + num(td.relvar_mis / td.relvar_us)
                                         : "(uniform sampling is exact here): is_tab " + num(td.relvar_is) +
                                               ", mis_tab " + num(td.relvar_mis)) +
                    "; largest f/pdf over the integral: is_tab " + num(td.max_weight_is) + ", mis_tab " +
                    num(td.max_weight_mis) + "; stand-in integral error " + num(td.stand_in / td.reference - 1);
  if (td.missed_is > 0)
    msg += "; is_tab never samples " + num(td.missed_is) + " of the integral (biased by that much: use mis_tab)";
  log_line(msg);
  const bool studies_is = std::find(spec.estimators.begin(), spec.estimators.end(), Estimator::IsTab) !=
                          spec.estimators.end();
  if (studies_is && !(td.relvar_is <= td.relvar_us))
    log_line("converge: warning: at theta_o " + fixed(theta_o, 4) +
             " is_tab has more variance than uniform sampling (the Gaussians' tails fall faster than f): "
             "use mis_tab, the robust default");
  return row;
}

// The problem of one direction and scene, mis_product's fractions tuned when asked.
Problem scene_problem(const StudySpec& spec, const StudyInputs& in, std::size_t si, double theta_o, double phi_o) {
  const Lighting& light = spec.scenes[si];
  Problem p = make_problem(in.table, in.set, theta_o, phi_o, light, spec.mis,
                           in.product ? &in.light_mix[si].mixture : nullptr);
  p.rgl = in.rgl.get();
  if (in.product && spec.product_auto) {
    const ProductTuning tu = tune_product_fractions(p);
    p.mis.product_fraction = tu.product_fraction;
    p.mis.product_light = tu.product_light;
    log_line("converge: theta_o " + fixed(theta_o, 4) + " " + light.name + ": mis_product fractions product " +
             short_num(tu.product_fraction) + ", light " + short_num(tu.product_light) + ", uniform " +
             short_num(1 - tu.product_fraction - tu.product_light) + " (predicted variance per sample " +
             short_num(tu.relvar) + ", largest f/pdf " + short_num(tu.max_weight) + ")");
  }
  return p;
}

// The light tail's rows of one direction and scene (its CSV), and its line in the log.
std::string light_tail_rows(const StudySpec& spec, const StudyInputs& in, std::size_t si, const Problem& p) {
  const Lighting& light = spec.scenes[si];
  const LightTail lt = light_tail(p, in.table_estimators);
  std::string rows;
  std::string tail_msg = "converge: theta_o " + fixed(p.theta_o, 4) + " " + light.name +
                         ": predicted variance per sample, largest f/pdf over the integral:";
  for (std::size_t e = 0; e < in.table_estimators.size(); ++e) {
    const LightMixture& lm = in.light_mix[si];
    rows += spec.table_label + "," + num(p.theta_o) + "," + num(p.phi_o) + "," + light.name + "," +
            estimator_name(in.table_estimators[e]) + "," + num(lt.relvar[e]) + "," + num(lt.max_weight[e]) + "," +
            num(lt.missed[e]) + "," +
            (in.product ? std::to_string(lm.k) + "," + num(lm.l1_rel) + "," + num(lm.fit_seconds) + "," +
                              std::to_string(p.product.components.size()) + "," + num(p.product_kept) + "," +
                              num(p.mis.product_fraction) + "," + num(p.mis.product_light)
                        : std::string(",,,,,,")) +
            "\n";
    tail_msg += std::string(e ? ";" : "") + " " + estimator_name(in.table_estimators[e]) + " " +
                short_num(lt.relvar[e]) + ", " + short_num(lt.max_weight[e]);
  }
  if (in.product)
    tail_msg += "; product of K " + std::to_string(p.product.components.size()) + " keeps " +
                short_num(p.product_kept) + " of its mass";
  log_line(tail_msg);
  return rows;
}

// One launch per estimator (the convergence rows), then `timing_rounds` more timed
// launches of the same shape, interleaved over the estimators so that a change in the
// machine's load hits every estimator alike: `best` is the fastest. The estimators
// without a kernel run on the CPU reference, timed once.
void run_estimators(const StudySpec& spec, const StudyInputs& in, const Problem& p, int timing_rounds,
                    Progress& progress, std::vector<RunSums>& sums, std::vector<double>& best) {
  for (const Estimator e : spec.estimators) {
    RunSums s;
    if (spec.cpu || !on_device(e)) {
      const auto t0 = std::chrono::steady_clock::now();
      s = integrate_cpu(p, e, spec.runs, spec.samples_max, spec.seed);
      s.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    } else {
      s = integrate_device(in.devices.front(), p, e, spec.runs, spec.samples_max, spec.seed);
    }
    best.push_back(s.seconds);
    sums.push_back(std::move(s));
    progress.advance();
  }
  for (int round = 0; round < timing_rounds; ++round)
    for (std::size_t i = 0; i < spec.estimators.size(); ++i) {
      if (on_device(spec.estimators[i]))
        best[i] = std::min(best[i], time_integrate_device(in.devices.front(), p, spec.estimators[i], spec.runs,
                                                          spec.samples_max, spec.seed));
      progress.advance();
    }
}

// The convergence rows of one direction and scene, and one summary line in the log.
void scene_rows(const StudySpec& spec, const Lighting& light, const Problem& p, double ref,
                const std::vector<RunSums>& sums, const std::vector<double>& best,
                std::vector<ConvergenceRow>& rows) {
  double var_us = -1, ns_us = -1;
  for (std::size_t i = 0; i < spec.estimators.size(); ++i)
    if (spec.estimators[i] == Estimator::UsTab) {
      const auto rs = convergence_rows(sums[i], ref, 0);
      var_us = rs.back().rmse * rs.back().rmse;
      ns_us = best[i] * 1e9 / (double(spec.runs) * double(spec.samples_max));
    }
  std::string line = "converge: theta_o " + fixed(p.theta_o, 4) + " " + light.name + ", N " +
                     std::to_string(spec.samples_max) + ": rel_rmse" +
                     (var_us > 0 ? " (us_tab's variance over it)" : "") + ", ns/sample" +
                     (ns_us > 0 ? " (over us_tab's)" : "") + ":";
  for (std::size_t i = 0; i < spec.estimators.size(); ++i) {
    const Estimator e = spec.estimators[i];
    const double ns = best[i] * 1e9 / (double(spec.runs) * double(spec.samples_max));
    auto rs = convergence_rows(sums[i], ref, ns);
    for (auto& r : rs) {
      r.table = spec.table_label;
      r.scene = light.name;
      r.estimator = estimator_name(e);
      r.theta_o = p.theta_o;
      r.phi_o = p.phi_o;
      r.uniform_fraction = p.mis.uniform_fraction;
    }
    const ConvergenceRow& last = rs.back();
    line += std::string(i ? ";" : "") + " " + estimator_name(e) + " " + short_num(last.rel_rmse);
    if (var_us > 0 && e != Estimator::UsTab && last.rmse > 0)
      line += " (" + short_num(var_us / (last.rmse * last.rmse)) + "x)";
    line += ", " + fixed(ns, 0) + (spec.cpu || on_device(e) ? "" : " (CPU)");
    if (ns_us > 0 && e != Estimator::UsTab) line += " (" + fixed(ns / ns_us, 2) + "x)";
    rows.insert(rows.end(), rs.begin(), rs.end());
  }
  log_line(line);
}

}  // namespace

std::vector<ConvergenceRow> run_study(const StudySpec& spec) {
  if (spec.samples_max == 0 || (spec.samples_max & (spec.samples_max - 1)))
    throw ConfigError("converge: samples_max must be a power of two");
  prepare_output(spec.csv);
  prepare_output(spec.tail_csv);
  if (!spec.light_tail_csv.empty()) prepare_output(spec.light_tail_csv);
  StudyInputs in(spec);
  read_inputs(spec, in);
  std::vector<ConvergenceRow> rows;
  std::string tail = std::string(kTailHeader) + "\n";
  std::string light_tail_text = std::string(kLightTailHeader) + "\n";
  const int timing_rounds = spec.cpu ? 0 : std::max(0, spec.timing_rounds);
  const std::size_t per_scene = spec.estimators.size() * std::size_t(1 + timing_rounds);
  Progress progress("converge " + spec.table_label, spec.directions.size() * spec.scenes.size() * per_scene,
                    "launches");
  std::size_t skipped = 0;
  for (const auto& [theta_o, phi_o] : spec.directions) {
    // A zero slice has nothing to integrate (and no CDF to sample): skip the direction,
    // keep the others.
    const TableSlice probe = blended_slice(in.table, in.set, theta_o, phi_o);
    if (!std::any_of(probe.f.begin(), probe.f.end(), [](float v) { return v > 0; })) {
      log_line("converge: warning: " + spec.table + " at theta_o " + fixed(theta_o, 4) + " phi_o " + fixed(phi_o, 4) +
               ": the table slice is zero everywhere (nothing to integrate): direction skipped");
      ++skipped;
      progress.advance(spec.scenes.size() * per_scene);
      continue;
    }
    tail += direction_tail(spec, in, theta_o, phi_o);
    for (std::size_t si = 0; si < spec.scenes.size(); ++si) {
      const Lighting& light = spec.scenes[si];
      const Problem p = scene_problem(spec, in, si, theta_o, phi_o);
      const double ref = table_integral(p);
      if (!(ref > 0) || !std::isfinite(ref))
        throw InputError("converge: the reference integral at theta_o " + num(theta_o) + " in scene '" + light.name +
                         "' is " + num(ref) + " (the lighting or the table slice is zero)");
      if (!spec.light_tail_csv.empty()) light_tail_text += light_tail_rows(spec, in, si, p);
      std::vector<RunSums> sums;
      std::vector<double> best;
      run_estimators(spec, in, p, timing_rounds, progress, sums, best);
      scene_rows(spec, light, p, ref, sums, best, rows);
    }
  }
  progress.finish();
  if (skipped == spec.directions.size())
    throw InputError(spec.table + ": the table slice is zero everywhere at every studied direction (nothing to integrate)");
  std::string text = std::string(kConvergenceHeader) + "\n";
  for (const auto& r : rows) text += format_row(r) + "\n";
  write_text_atomic(spec.csv, text);
  write_text_atomic(spec.tail_csv, tail);
  if (!spec.light_tail_csv.empty()) write_text_atomic(spec.light_tail_csv, light_tail_text);
  log_line("converge: wrote " + spec.csv + " (" + std::to_string(rows.size()) + " rows), " + spec.tail_csv +
           (spec.light_tail_csv.empty() ? "" : " and " + spec.light_tail_csv));
  return rows;
}

}  // namespace bsdfmix
