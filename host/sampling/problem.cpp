// The problem of one omega_o: the flattened mixture, the blended table slice, its CDF.
#include <algorithm>
#include <cmath>

#include "core/error.hpp"
#include "sampling/sampling.hpp"

namespace bsdfmix {

std::uint32_t estimator_stream(int estimator) { return 0x65737430u + std::uint32_t(estimator); }  // "est0".."est:"

static int block_images(double sigma_c) {
  // Offsets from the conditional mean of the images beyond the nearest (|u0| <= pi), nearest
  // first: j = 2n - 1 at u0 -+ 2 pi n (the other side), j = 2n at u0 +- 2 pi n (the same
  // side); |u_j| >= j pi, and u_j^2 - u0^2 >= L_j = 4 pi^2 n (n - 1) (j odd) or 4 pi^2 n^2
  // (j even). Image j is left out when either bound makes it negligible: beyond 9 sigma
  // (below 2.6e-18 of the component's peak, the header's cut) or below e^-18 = 2^-26 of
  // the component's own term at the nearest image (so below float rounding of the pdf).
  if (!(9 * sigma_c > kPi)) return 0;
  int images = 1;
  for (int j = 2; j < 64; ++j) {
    const double n = double((j + 1) / 2);
    const double L = j % 2 ? 4 * kPi * kPi * n * (n - 1) : 4 * kPi * kPi * n * n;
    if (9 * sigma_c > j * kPi && L / (2 * sigma_c * sigma_c) < 18.0) images = j;
    else break;
  }
  return images;
}

QueryMixture make_query(const mix::MixtureSet& set, double theta_o, double phi_o, double f_unit) {
  if (set.interpolation == mix::Interpolation::Displace)
    return make_query(set.serving(theta_o, phi_o), theta_o, phi_o, f_unit);
  QueryMixture qm;
  qm.domain = set.domain;
  qm.map = set.map;
  qm.blend = set.blend(theta_o, phi_o);
  const auto& b = qm.blend;
  qm.q.assign(QueryMixture::kQuery, 0.f);
  qm.q[0] = float(b.count);
  qm.q[1] = float(b.rotate);
  std::size_t total = 0, max_n = 0;
  double cum = 0;
  // The pdf's constants, one component per lane of blocks of kLanes (kernels/sample.cl,
  // mixture_sums). At (dt, dp) from the mean, a component's term (blend weight x weight x
  // normal density) is 2^(lw + a_t dt^2 + a_p u^2), u = dp - m dt the phi offset from the
  // conditional mean given theta (m = -i_tp / i_pp the regression slope, a_t = -log2(e) /
  // (2 s_tt), a_p = -log2(e) i_pp / 2, lw = log2(blend weight x weight x norm)). The kernel
  // takes the phi image nearest the conditional mean, |u| <= pi, then `images` more, nearest
  // first (block_images below). Components are sorted by that count so that blocks are
  // alike; padding lanes have lw = -1000 (a zero term).
  constexpr double kLog2e = 1.4426950408889634;
  struct Lane {
    float v[QueryMixture::kRows];
    int images;
  };
  std::vector<Lane> lanes;
  for (int k = 0; k < b.count; ++k) {
    const mix::SliceMixture& s = set.slices[std::size_t(b.slice[k])];
    qm.q[std::size_t(2 + k)] = float(b.weight[k]);
    qm.q[std::size_t(6 + k)] = float(total);
    qm.q[std::size_t(10 + k)] = float(s.components.size());
    cum += b.weight[k];
    qm.q[std::size_t(19 + k)] = float(cum);
    qm.q[std::size_t(24 + k)] = float(s.base);  // kernels/sample.cl Q_BASE
    qm.q[28] += float(b.weight[k] * s.base);
    qm.q[29] += float(b.weight[k] * s.scale * s.base / f_unit);
    max_n = std::max(max_n, s.components.size());
    for (std::size_t j = 0; j < s.components.size(); ++j) {
      const mix::Gaussian& g = s.components[j];
      const float c[16] = {float(g.mu_t), float(g.mu_p), float(g.i_tt), float(g.i_tp), float(g.i_pp),
                           float(g.l_tt), float(g.l_pt), float(g.l_pp),
                           float(b.weight[k] * g.weight * g.norm), float(b.weight[k] * s.scale * g.weight * g.norm / f_unit),
                           float(g.cut), float(g.images), float(s.cdf[j]), 0.f, 0.f, 0.f};
      qm.comps.insert(qm.comps.end(), c, c + 16);
      const double w = b.weight[k] * g.weight * g.norm;
      Lane l{};
      l.v[0] = float(g.mu_t);
      l.v[1] = float(wrap_phi(g.mu_p));
      l.v[2] = float(-g.i_tp / g.i_pp);
      l.v[3] = float(-0.5 * kLog2e / g.s_tt);
      l.v[4] = float(-0.5 * kLog2e * g.i_pp);
      l.v[5] = w > 0 ? float(std::max(std::log2(w), -1000.0)) : -1000.f;
      l.v[6] = float(s.scale / f_unit);
      l.images = block_images(1.0 / std::sqrt(g.i_pp));
      lanes.push_back(l);
    }
    total += s.components.size();
  }
  qm.q[14] = float(total);
  if (total > 1u << 20) throw InputError("mixture query: too many components");
  std::stable_sort(lanes.begin(), lanes.end(), [](const Lane& x, const Lane& y) { return x.images > y.images; });
  const std::size_t blocks = (lanes.size() + QueryMixture::kLanes - 1) / QueryMixture::kLanes;
  for (std::size_t bl = 0; bl < blocks; ++bl)
    for (std::size_t r = 0; r < QueryMixture::kRows; ++r)
      for (std::size_t i = 0; i < QueryMixture::kLanes; ++i) {
        const std::size_t c = bl * QueryMixture::kLanes + i;
        float v = c < lanes.size() ? lanes[c].v[r] : (r == 5 ? -1000.f : 0.f);
        if (r == 7) v = i == 0 ? float(lanes[bl * QueryMixture::kLanes].images) : 0.f;  // sorted: the block's most
        qm.pdf.push_back(v);
      }
  qm.q[15] = float(blocks);
  std::size_t step = 1;
  while (step * 2 <= max_n) step *= 2;
  qm.q[18] = float(step);
  return qm;
}

QueryMixture make_query(const mix::SliceMixture& mixture, Domain domain) {
  mix::MixtureSet one;
  one.domain = domain;
  one.map = mixture.map;
  one.azimuthal = true;
  one.grid_theta_o = {0.0};
  one.grid_phi_o = {0.0};
  one.slices = {mixture};
  one.slices[0].theta_o = 0;
  one.slices[0].phi_o = 0;
  one.slices[0].scale = 1;
  one.prepare();
  return make_query(one, 0.0, 0.0);
}

// ---- the table slice --------------------------------------------------------------------

double TableSlice::theta_edge(std::size_t i) const {
  return std::clamp(th0 + dth * double(i), theta_lo(domain), theta_hi(domain));
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
  if (set.domain != m.domain)
    throw InputError(table.path() + ": the table's domain differs from the mixture file's");
  const auto b = set.blend(theta_o, phi_o);
  t.rotate = b.rotate;
  std::vector<double> acc(t.n_theta * t.n_phi, 0.0);
  for (int k = 0; k < b.count; ++k) {
    const mix::SliceMixture& s = set.slices[std::size_t(b.slice[k])];
    const std::size_t to = nearest_center(m.theta_o, s.theta_o), po = nearest_center(m.phi_o, s.phi_o);
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
  return {float(table.th0),   float(table.dth),           float(table.n_theta),        float(table.ph0),
          float(table.dph),   float(table.n_phi),         float(mis.uniform_fraction), float(mis.light_fraction),
          float(mis.product_fraction), float(mis.product_light), mis.power ? 1.f : 0.f, 0.f,
          0.f, 0.f, 0.f, 0.f};
}

Problem make_problem(const TableReader& table, const mix::MixtureSet& set, double theta_o, double phi_o,
                     const Lighting& light, double uniform_fraction) {
  MisOptions mis;
  mis.uniform_fraction = uniform_fraction;
  return make_problem(table, set, theta_o, phi_o, light, mis, nullptr);
}

Problem make_problem(const TableReader& table, const mix::MixtureSet& set, double theta_o, double phi_o,
                     const Lighting& light, const MisOptions& mis, const mix::SliceMixture* light_mixture) {
  if (!(mis.uniform_fraction >= 0 && mis.uniform_fraction < 1) || !(mis.light_fraction >= 0 && mis.light_fraction < 1) ||
      !(mis.product_fraction > 0 && mis.product_light >= 0 && mis.product_fraction + mis.product_light <= 1))
    throw ConfigError("converge: the MIS fractions must lie in [0, 1) and the product's add up to at most 1");
  Problem p;
  p.set = &set;
  if (set.interpolation == mix::Interpolation::Displace) {
    p.serving = std::make_shared<const mix::MixtureSet>(set.serving(theta_o, phi_o));
    p.set = p.serving.get();
  }
  p.theta_o = theta_o;
  p.phi_o = phi_o;
  p.query = make_query(*p.set, theta_o, phi_o);
  p.table = blended_slice(table, set, theta_o, phi_o);
  p.cdf = build_cdf(p.table);
  p.light = light;
  p.light.domain = p.table.domain;
  p.light_sampler = make_light_sampler(p.light);
  p.mis = mis;
  if (mis.earned) p.mis.uniform_fraction = set.defensive(theta_o, phi_o);
  if (light_mixture) {
    p.product = p.set->product_with(theta_o, phi_o, *light_mixture, mis.product, nullptr, &p.product_kept);
    p.product_query = make_query(p.product, p.table.domain);
    p.has_product = true;
  }
  return p;
}

}  // namespace bsdfmix
