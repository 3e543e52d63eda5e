// The stand-in against the table at every table slice.
#include "compare/compare.hpp"

#include <algorithm>
#include <cmath>
#include <set>
#include <sstream>

#include "core/domain.hpp"
#include "core/error.hpp"
#include "core/format.hpp"
#include "core/progress.hpp"
#include "core/stats.hpp"
#include "fit/amplitudes.hpp"
#include "io/mixture_file.hpp"
#include "io/table.hpp"

namespace bsdfmix {

namespace {

std::string num(double v) { return format_number(v, "%.6g"); }

// The channels that are noise around zero, as "rgb" letters ("" for none).
std::string noise_channels(const SliceComparison& r) {
  std::string s;
  for (int q = 0; q < 3; ++q)
    if (r.noise[q]) s += "rgb"[q];
  return s;
}

}  // namespace

namespace {

// The set that serves omega_o as a renderer sees it: a set that displaces is served by a
// one-slice set per omega_o (the same mixture), kept in `view`.
const mix::MixtureSet& serving(const mix::MixtureSet& set, double theta_o, double phi_o, mix::MixtureSet& view) {
  if (set.interpolation != mix::Interpolation::Displace) return set;
  view = set.serving(theta_o, phi_o);
  return view;
}

// The stand-in's albedo at omega_o: its integral of f [cos theta_i] d omega_i by the
// midpoint rule on the table's cells (weights `g`).
double stand_in_albedo(const mix::MixtureSet& set, const TableMeta& m, const std::vector<double>& g, double theta_o,
                       double phi_o) {
  mix::MixtureSet view;
  const mix::MixtureSet& serve = serving(set, theta_o, phi_o, view);
  double a = 0;
  for (std::size_t i = 0; i < m.theta_i.size(); ++i)
    for (std::size_t j = 0; j < m.phi_i.size(); ++j)
      a += g[i * m.phi_i.size() + j] * serve.eval_f(theta_o, phi_o, m.theta_i[i], m.phi_i[j]);
  return a;
}

// One table slice (t, p) against the stand-in.
SliceComparison compare_slice(const mix::MixtureSet& set, const TableReader& reader, const std::vector<double>& g,
                              std::size_t t, std::size_t p) {
  const TableMeta& m = reader.meta();
  SliceComparison c;
  c.slice = m.slice_index(t, p);
  c.theta_o = m.theta_o[t];
  c.phi_o = m.phi_o[p];
  mix::MixtureSet view;
  const mix::MixtureSet& serve = serving(set, c.theta_o, c.phi_o, view);
  const std::vector<float> f = reader.read_slice(t, p);
  const std::vector<float> rgb = m.rgb ? reader.read_slice_rgb(t, p) : std::vector<float>{};
  double d = 0, tot = 0, est = 0, drgb[3] = {0, 0, 0}, trgb[3] = {0, 0, 0}, ergb[3] = {0, 0, 0}, dneg = 0;
  double tneg[3] = {0, 0, 0}, table_int = 0;
  const std::size_t np = m.phi_i.size();
  for (std::size_t i = 0; i < m.theta_i.size(); ++i)
    for (std::size_t j = 0; j < np; ++j) {
      const std::size_t k = i * np + j;
      // the table's phi axis is the mixture's (phi_i - phi_o under symmetry, with phi_o 0)
      const double phi = m.phi_i[j];
      const double fhat = serve.eval_f(c.theta_o, c.phi_o, m.theta_i[i], phi);
      d += g[k] * std::abs(fhat - double(f[k]));
      tot += g[k] * std::abs(double(f[k]));
      est += g[k] * fhat;
      table_int += g[k] * double(f[k]);
      if (!m.rgb) continue;
      double ch[3];
      serve.eval_rgb(c.theta_o, c.phi_o, m.theta_i[i], phi, ch);
      for (int q = 0; q < 3; ++q) {
        const double tv = rgb[3 * k + std::size_t(q)], e = g[k] * std::abs(ch[q] - tv);
        drgb[q] += e;
        trgb[q] += g[k] * std::abs(tv);
        ergb[q] += g[k] * ch[q] - g[k] * tv;
        if (tv < 0) dneg += e, tneg[q] -= g[k] * tv;
      }
    }
  c.l1 = tot > 0 ? d / tot : 0;
  c.energy = table_int > 0 ? est / table_int - 1 : 0;
  c.albedo = table_int;
  c.albedo_stand_in = est;
  if (m.rgb) {
    const double dsum = drgb[0] + drgb[1] + drgb[2], tsum = trgb[0] + trgb[1] + trgb[2];
    for (int q = 0; q < 3; ++q) {
      c.l1_rgb[q] = trgb[q] > 0 ? drgb[q] / trgb[q] : 0;
      c.energy_rgb[q] = trgb[q] > 0 ? ergb[q] / trgb[q] : 0;
      c.noise[q] = is_noise(tneg[q], trgb[q]);
    }
    c.rgb_error = tsum > 0 ? dsum / tsum : 0;
    c.negative_share = dsum > 0 ? dneg / dsum : 0;
  }
  return c;
}

// The albedos at `theta_o` (phi_o the table's first): the table's interpolated linearly in
// theta_o between its two nearest rows (the nearest alone beyond the first or last).
AlbedoAt albedo_at(const mix::MixtureSet& set, const TableMeta& m, const std::vector<double>& g,
                   const std::vector<SliceComparison>& slices, double theta_o) {
  AlbedoAt a;
  a.theta_o = theta_o;
  const std::vector<double>& rows = m.theta_o;
  const auto up = std::upper_bound(rows.begin(), rows.end(), theta_o);
  a.row_hi = std::min<std::size_t>(std::size_t(up - rows.begin()), rows.size() - 1);
  a.row_lo = up == rows.begin() ? 0 : std::size_t(up - rows.begin()) - 1;
  a.theta_lo = rows[a.row_lo];
  a.theta_hi = rows[a.row_hi];
  const double span = a.theta_hi - a.theta_lo;
  const double w = span > 0 ? (theta_o - rows[a.row_lo]) / span : 0;
  a.table = (1 - w) * slices[m.slice_index(a.row_lo, 0)].albedo + w * slices[m.slice_index(a.row_hi, 0)].albedo;
  a.stand_in = stand_in_albedo(set, m, g, theta_o, m.phi_o.front());
  return a;
}

}  // namespace

Comparison compare_stand_in(const std::string& mixture, const std::string& table, const std::vector<double>& theta_o) {
  const MixtureFile mf = read_mixture_file(mixture);
  const TableReader reader(table);
  const TableMeta& m = reader.meta();
  const std::string both = "compare " + mixture + " " + table;
  if (mf.domain != m.domain) throw InputError(both + ": the mixture is of a " + domain_name(mf.domain) +
                                              " table, the table is " + domain_name(m.domain));
  if (mf.azimuthal != m.azimuthal) throw InputError(both + ": the two differ in azimuthal symmetry");
  if (mf.table_theta_o != m.theta_o || mf.table_phi_o != m.phi_o)
    throw InputError(both + ": the mixture was fitted on other omega_o axes than the table's");
  for (double t : theta_o)
    if (!(t >= theta_lo(m.domain) && t <= theta_hi(m.domain)))
      throw InputError(both + ": theta_o " + format_number(t * 180 / kPi, "%g") + " deg is outside the " +
                       domain_name(m.domain) + " domain");
  const mix::MixtureSet set = to_mixture_set(mf);
  std::set<std::pair<double, double>> fitted;
  for (std::size_t s = 0; s < mf.slices(); ++s) fitted.insert({mf.theta_o[s], mf.phi_o[s]});

  Comparison out;
  out.rgb = m.rgb;
  const std::vector<float> ones(m.cells_per_slice(), 1.f);
  const std::vector<double> g = integrand_weights(m.domain, m.theta_i, m.phi_i, ones.data());
  Progress progress("compare " + mixture, m.n_slices(), "slices");
  for (std::size_t t = 0; t < m.theta_o.size(); ++t)
    for (std::size_t p = 0; p < m.phi_o.size(); ++p) {
      SliceComparison c = compare_slice(set, reader, g, t, p);
      c.fitted = fitted.count({c.theta_o, c.phi_o}) > 0;
      out.slices.push_back(c);
      progress.advance();
    }
  progress.finish();
  for (double t : theta_o) out.asked.push_back(albedo_at(set, m, g, out.slices, t));
  return out;
}

std::string comparison_csv(const Comparison& c) {
  std::ostringstream s;
  s << "slice,theta_o,phi_o,fitted,l1_rel,l1_r,l1_g,l1_b,rgb_error,rgb_negative_share,energy,energy_r,energy_g,"
       "energy_b,noise,albedo,albedo_stand_in\n";
  for (const SliceComparison& r : c.slices)
    s << r.slice << "," << num(r.theta_o) << "," << num(r.phi_o) << "," << (r.fitted ? 1 : 0) << "," << num(r.l1)
      << "," << num(r.l1_rgb[0]) << "," << num(r.l1_rgb[1]) << "," << num(r.l1_rgb[2]) << "," << num(r.rgb_error)
      << "," << num(r.negative_share) << "," << num(r.energy) << "," << num(r.energy_rgb[0]) << ","
      << num(r.energy_rgb[1]) << "," << num(r.energy_rgb[2]) << "," << noise_channels(r) << "," << num(r.albedo) << ","
      << num(r.albedo_stand_in) << "\n";
  return s.str();
}

namespace {

// The summary's albedo lines: ranges and largest difference over the slices, then each
// theta_o asked for.
std::string albedo_lines(const Comparison& c) {
  if (c.slices.empty()) return "";
  std::ostringstream s;
  double lo = c.slices[0].albedo, hi = lo, slo = c.slices[0].albedo_stand_in, shi = slo, worst = 0;
  const SliceComparison* at = &c.slices[0];
  for (const SliceComparison& r : c.slices) {
    lo = std::min(lo, r.albedo), hi = std::max(hi, r.albedo);
    slo = std::min(slo, r.albedo_stand_in), shi = std::max(shi, r.albedo_stand_in);
    if (std::abs(r.albedo_stand_in - r.albedo) > worst) worst = std::abs(r.albedo_stand_in - r.albedo), at = &r;
  }
  auto deg = [](double rad) { return format_number(rad * 180 / kPi, "%.4g"); };
  s << "  albedo (integral of f cos theta_i d omega_i): table " << num(lo) << " .. " << num(hi) << ", stand-in "
    << num(slo) << " .. " << num(shi) << "; largest difference " << num(at->albedo_stand_in - at->albedo)
    << " at theta_o " << deg(at->theta_o) << " deg\n";
  for (const AlbedoAt& a : c.asked)
    s << "  albedo at theta_o " << deg(a.theta_o) << " deg: table " << num(a.table)
      << (a.row_lo == a.row_hi ? " (its nearest row, at " + deg(a.theta_lo) + " deg)"
                               : " (linear between its rows at " + deg(a.theta_lo) + " and " + deg(a.theta_hi) + " deg)")
      << ", stand-in " << num(a.stand_in) << " ("
      << (a.table > 0 ? format_number(100 * (a.stand_in / a.table - 1), "%+.2f") + "%" : std::string("n/a")) << ")\n";
  return s.str();
}

}  // namespace

std::string comparison_summary(const Comparison& c) {
  std::ostringstream s;
  auto line = [&](const char* what, bool pick_fitted, bool all) {
    std::vector<double> l1, rgb, energy;
    std::size_t noisy[3] = {0, 0, 0};
    for (const SliceComparison& r : c.slices) {
      if (!all && r.fitted != pick_fitted) continue;
      l1.push_back(r.l1);
      rgb.push_back(r.rgb_error - r.rgb_error * r.negative_share);
      double e = std::abs(r.energy);  // a noise channel has no integral to keep: counted, not compared
      for (int q = 0; q < 3; ++q) {
        if (!r.noise[q]) e = std::max(e, std::abs(r.energy_rgb[q]));
        noisy[q] += r.noise[q];
      }
      energy.push_back(e);
    }
    if (l1.empty()) return;
    s << "  " << what << " (" << l1.size() << " slices): relative L1 median " << percent_text(quantile(l1, 0.5))
      << ", p90 " << percent_text(quantile(l1, 0.9));
    if (c.rgb)
      s << "; RGB error less its negative share median " << percent_text(quantile(rgb, 0.5)) << ", p90 "
        << percent_text(quantile(rgb, 0.9));
    s << "; largest energy error " << percent_text(quantile(energy, 1.0));
    for (int q = 0; q < 3; ++q)
      if (noisy[q]) s << " (" << "RGB"[q] << " is noise around zero in " << noisy[q] << " slices, not compared)";
    s << "\n";
  };
  line("every table slice", false, true);
  line("fitted", true, false);
  line("between fitted", false, false);
  s << albedo_lines(c);
  return s.str();
}

double comparison_error(const Comparison& c, double q) {
  std::vector<double> e;
  for (const SliceComparison& r : c.slices) e.push_back(c.rgb ? r.rgb_error - r.rgb_error * r.negative_share : r.l1);
  return quantile(e, q);
}

}  // namespace bsdfmix
