// The problem of one omega_o: the flattened mixture, the blended table slice, its CDF.
#include <algorithm>
#include <cmath>

#include "core/error.hpp"
#include "sampling/sampling.hpp"

namespace bsdfmix {

std::uint32_t estimator_stream(int estimator) { return 0x65737430u + std::uint32_t(estimator); }  // "est0".."est5"

const char* estimator_name(Estimator e) {
  switch (e) {
    case Estimator::UsTab: return "us_tab";
    case Estimator::UsGmm: return "us_gmm";
    case Estimator::IsTab: return "is_tab";
    case Estimator::IsGmm: return "is_gmm";
    case Estimator::MisTab: return "mis_tab";
    case Estimator::CdfTab: return "cdf_tab";
  }
  return "?";
}

Estimator parse_estimator(const std::string& name, const std::string& where) {
  for (int i = 0; i < kEstimators; ++i)
    if (name == estimator_name(Estimator(i))) return Estimator(i);
  throw ConfigError(where + ": unknown estimator '" + name +
                    "' (expected us_tab, us_gmm, is_tab, is_gmm, mis_tab or cdf_tab)");
}

bool uses_table(Estimator e) { return e != Estimator::UsGmm && e != Estimator::IsGmm; }

QueryMixture make_query(const mix::MixtureSet& set, double theta_o, double phi_o, double f_unit) {
  QueryMixture qm;
  qm.domain = set.domain == mix::Domain::Fiber ? Domain::Fiber : Domain::Hemisphere;
  qm.blend = set.blend(theta_o, phi_o);
  const auto& b = qm.blend;
  qm.q.assign(16, 0.f);
  qm.q[0] = float(b.count);
  qm.q[1] = float(b.rotate);
  std::size_t total = 0;
  for (int k = 0; k < b.count; ++k) {
    const mix::SliceMixture& s = set.slices[std::size_t(b.slice[k])];
    qm.q[std::size_t(2 + k)] = float(b.weight[k]);
    qm.q[std::size_t(6 + k)] = float(total);
    qm.q[std::size_t(10 + k)] = float(s.components.size());
    for (std::size_t j = 0; j < s.components.size(); ++j) {
      const mix::Gaussian& g = s.components[j];
      const float c[16] = {float(g.mu_t), float(g.mu_p), float(g.i_tt), float(g.i_tp), float(g.i_pp),
                           float(g.l_tt), float(g.l_pt), float(g.l_pp),
                           float(b.weight[k] * g.weight * g.norm), float(b.weight[k] * s.scale * g.weight * g.norm / f_unit),
                           float(g.cut), float(g.images), float(s.cdf[j]), 0.f, 0.f, 0.f};
      qm.comps.insert(qm.comps.end(), c, c + 16);
    }
    total += s.components.size();
  }
  qm.q[14] = float(total);
  if (total > 1u << 20) throw InputError("mixture query: too many components");
  return qm;
}

// ---- the table slice --------------------------------------------------------------------

double TableSlice::theta_edge(std::size_t i) const {
  return std::clamp(th0 + dth * double(i), theta_min(domain), theta_max(domain));
}

double TableSlice::f_at(double theta, double phi_world) const {
  const double fi = std::floor((theta - th0) / dth);
  if (!(fi >= 0) || fi >= double(n_theta)) return 0;
  const double pl = wrap_phi(phi_world - rotate);
  long j = long(std::floor((pl - ph0) / dph)) % long(n_phi);
  if (j < 0) j += long(n_phi);
  return f[std::size_t(fi) * n_phi + std::size_t(j)];
}

double TableSlice::cell_weight(std::size_t i) const {
  const double a = theta_edge(i), b = theta_edge(i + 1);
  if (domain == Domain::Fiber) return (std::sin(b) - std::sin(a)) * dph;
  return 0.5 * (std::sin(b) * std::sin(b) - std::sin(a) * std::sin(a)) * dph;
}

double TableSlice::cell_solid_angle(std::size_t i) const {
  const double a = theta_edge(i), b = theta_edge(i + 1);
  if (domain == Domain::Fiber) return (std::sin(b) - std::sin(a)) * dph;
  return (std::cos(a) - std::cos(b)) * dph;
}

namespace {

std::size_t nearest(const std::vector<double>& axis, double x) {
  std::size_t best = 0;
  for (std::size_t i = 1; i < axis.size(); ++i)
    if (std::abs(axis[i] - x) < std::abs(axis[best] - x)) best = i;
  return best;
}

}  // namespace

TableSlice blended_slice(const TableReader& table, const mix::MixtureSet& set, double theta_o, double phi_o) {
  const TableMeta& m = table.meta();
  TableSlice t;
  t.domain = m.domain;
  t.n_theta = m.theta_i.size();
  t.n_phi = m.phi_i.size();
  t.dth = axis_step(m.theta_i);
  t.dph = axis_step(m.phi_i);
  t.th0 = m.theta_i.front() - t.dth / 2;
  t.ph0 = m.phi_i.front() - t.dph / 2;
  if ((set.domain == mix::Domain::Fiber) != (m.domain == Domain::Fiber))
    throw InputError(table.path() + ": the table's domain differs from the mixture file's");
  const auto b = set.blend(theta_o, phi_o);
  t.rotate = b.rotate;
  std::vector<double> acc(t.n_theta * t.n_phi, 0.0);
  for (int k = 0; k < b.count; ++k) {
    const mix::SliceMixture& s = set.slices[std::size_t(b.slice[k])];
    const std::size_t to = nearest(m.theta_o, s.theta_o), po = nearest(m.phi_o, s.phi_o);
    const std::vector<float> f = table.read_slice(to, po);
    for (std::size_t c = 0; c < acc.size(); ++c) acc[c] += b.weight[k] * double(f[c]);
  }
  t.f.assign(acc.begin(), acc.end());
  return t;
}

CellCdf build_cdf(const TableSlice& t) {
  CellCdf c;
  c.marginal.assign(t.n_theta + 1, 0.f);
  c.conditional.assign(t.n_theta * (t.n_phi + 1), 0.f);
  std::vector<double> rows(t.n_theta, 0.0);
  double total = 0;
  for (std::size_t i = 0; i < t.n_theta; ++i) {
    const double w = t.cell_weight(i);
    double acc = 0;
    std::vector<double> cum(t.n_phi + 1, 0.0);
    for (std::size_t j = 0; j < t.n_phi; ++j) {
      acc += double(t.f[i * t.n_phi + j]) * w;
      cum[j + 1] = acc;
    }
    float* row = &c.conditional[i * (t.n_phi + 1)];
    for (std::size_t j = 0; j <= t.n_phi; ++j)
      row[j] = acc > 0 ? float(cum[j] / acc) : float(double(j) / double(t.n_phi));
    row[t.n_phi] = 1.f;
    rows[i] = acc;
    total += acc;
  }
  if (!(total > 0)) throw InputError("cdf_tab: the table slice is zero everywhere");
  double acc = 0;
  for (std::size_t i = 0; i < t.n_theta; ++i) {
    acc += rows[i];
    c.marginal[i + 1] = float(acc / total);
  }
  c.marginal[t.n_theta] = 1.f;
  return c;
}

std::vector<float> Problem::geometry() const {
  return {float(table.th0), float(table.dth), float(table.n_theta), float(table.ph0),
          float(table.dph), float(table.n_phi), float(uniform_fraction), 0.f};
}

Problem make_problem(const TableReader& table, const mix::MixtureSet& set, double theta_o, double phi_o,
                     const Lighting& light, double uniform_fraction) {
  Problem p;
  p.set = &set;
  p.theta_o = theta_o;
  p.phi_o = phi_o;
  p.query = make_query(set, theta_o, phi_o);
  p.table = blended_slice(table, set, theta_o, phi_o);
  p.cdf = build_cdf(p.table);
  p.light = light;
  p.light.domain = p.table.domain;
  p.uniform_fraction = uniform_fraction;
  return p;
}

}  // namespace bsdfmix
