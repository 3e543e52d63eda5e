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
#include "fit/amplitudes.hpp"
#include "io/mixture_file.hpp"
#include "io/table.hpp"

namespace bsdfmix {

namespace {

std::string num(double v) { return format_number(v, "%.6g"); }

double quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, std::size_t(std::ceil(q * double(v.size()))) - (q > 0 ? 1 : 0))];
}

// The channels that are noise around zero, as "rgb" letters ("" for none).
std::string noise_channels(const SliceComparison& r) {
  std::string s;
  for (int q = 0; q < 3; ++q)
    if (r.noise[q]) s += "rgb"[q];
  return s;
}

}  // namespace

Comparison compare_stand_in(const std::string& mixture, const std::string& table) {
  const MixtureFile mf = read_mixture_file(mixture);
  const TableReader reader(table);
  const TableMeta& m = reader.meta();
  const std::string both = "compare " + mixture + " " + table;
  if (mf.domain != m.domain) throw InputError(both + ": the mixture is of a " + domain_name(mf.domain) +
                                              " table, the table is " + domain_name(m.domain));
  if (mf.azimuthal != m.azimuthal) throw InputError(both + ": the two differ in azimuthal symmetry");
  if (mf.table_theta_o != m.theta_o || mf.table_phi_o != m.phi_o)
    throw InputError(both + ": the mixture was fitted on other omega_o axes than the table's");
  const mix::MixtureSet set = to_mixture_set(mf);
  std::set<std::pair<double, double>> fitted;
  for (std::size_t s = 0; s < mf.slices(); ++s) fitted.insert({mf.theta_o[s], mf.phi_o[s]});

  Comparison out;
  out.rgb = m.rgb;
  const std::size_t nt = m.theta_i.size(), np = m.phi_i.size();
  const std::vector<float> ones(m.cells_per_slice(), 1.f);
  const std::vector<double> g = integrand_weights(m.domain, m.theta_i, m.phi_i, ones.data());
  Progress progress("compare " + mixture, m.n_slices(), "slices");
  for (std::size_t t = 0; t < m.theta_o.size(); ++t)
    for (std::size_t p = 0; p < m.phi_o.size(); ++p) {
      SliceComparison c;
      c.slice = m.slice_index(t, p);
      c.theta_o = m.theta_o[t];
      c.phi_o = m.phi_o[p];
      c.fitted = fitted.count({c.theta_o, c.phi_o}) > 0;
      // a set that displaces is served by a one-slice set per omega_o (the same mixture)
      const mix::MixtureSet view =
          set.interpolation == mix::Interpolation::Displace ? set.serving(c.theta_o, c.phi_o) : mix::MixtureSet{};
      const mix::MixtureSet& serve = set.interpolation == mix::Interpolation::Displace ? view : set;
      const std::vector<float> f = reader.read_slice(t, p);
      const std::vector<float> rgb = m.rgb ? reader.read_slice_rgb(t, p) : std::vector<float>{};
      double d = 0, tot = 0, est = 0, drgb[3] = {0, 0, 0}, trgb[3] = {0, 0, 0}, ergb[3] = {0, 0, 0}, dneg = 0;
      double tneg[3] = {0, 0, 0};
      for (std::size_t i = 0; i < nt; ++i)
        for (std::size_t j = 0; j < np; ++j) {
          const std::size_t k = i * np + j;
          // the table's phi axis is the mixture's (phi_i - phi_o under symmetry, with phi_o 0)
          const double phi = m.phi_i[j];
          const double fhat = serve.eval_f(c.theta_o, c.phi_o, m.theta_i[i], phi);
          d += g[k] * std::abs(fhat - double(f[k]));
          tot += g[k] * std::abs(double(f[k]));
          est += g[k] * fhat;
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
      double table_int = 0;
      for (std::size_t k = 0; k < f.size(); ++k) table_int += g[k] * double(f[k]);
      c.l1 = tot > 0 ? d / tot : 0;
      c.energy = table_int > 0 ? est / table_int - 1 : 0;
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
      out.slices.push_back(c);
      progress.advance();
    }
  progress.finish();
  return out;
}

std::string comparison_csv(const Comparison& c) {
  std::ostringstream s;
  s << "slice,theta_o,phi_o,fitted,l1_rel,l1_r,l1_g,l1_b,rgb_error,rgb_negative_share,energy,energy_r,energy_g,"
       "energy_b,noise\n";
  for (const SliceComparison& r : c.slices)
    s << r.slice << "," << num(r.theta_o) << "," << num(r.phi_o) << "," << (r.fitted ? 1 : 0) << "," << num(r.l1)
      << "," << num(r.l1_rgb[0]) << "," << num(r.l1_rgb[1]) << "," << num(r.l1_rgb[2]) << "," << num(r.rgb_error)
      << "," << num(r.negative_share) << "," << num(r.energy) << "," << num(r.energy_rgb[0]) << ","
      << num(r.energy_rgb[1]) << "," << num(r.energy_rgb[2]) << "," << noise_channels(r) << "\n";
  return s.str();
}

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
    s << "  " << what << " (" << l1.size() << " slices): relative L1 median " << format_number(100 * quantile(l1, 0.5), "%.2f")
      << "%, p90 " << format_number(100 * quantile(l1, 0.9), "%.2f") << "%";
    if (c.rgb)
      s << "; RGB error less its negative share median " << format_number(100 * quantile(rgb, 0.5), "%.2f") << "%, p90 "
        << format_number(100 * quantile(rgb, 0.9), "%.2f") << "%";
    s << "; largest energy error " << format_number(100 * quantile(energy, 1.0), "%.2f") << "%";
    for (int q = 0; q < 3; ++q)
      if (noisy[q]) s << " (" << "RGB"[q] << " is noise around zero in " << noisy[q] << " slices, not compared)";
    s << "\n";
  };
  line("every table slice", false, true);
  line("fitted", true, false);
  line("between fitted", false, false);
  return s.str();
}

double comparison_error(const Comparison& c, double q) {
  std::vector<double> e;
  for (const SliceComparison& r : c.slices) e.push_back(c.rgb ? r.rgb_error - r.rgb_error * r.negative_share : r.l1);
  return quantile(e, q);
}

}  // namespace bsdfmix
