// cdf_tab: the table's own piecewise-constant CDF (kernels/sample.cl ESTIMATOR 5); in the
// renderer the BSDF draw alone.
#include "sampling/draws.hpp"
#include "sampling/estimator_builtins.hpp"

namespace bsdfmix {
namespace {

using namespace draws;

double estimate(const Problem& p, const double u[4]) {
  const TableSlice& t = p.table;
  const std::size_t i = cdf_find(p.cdf.marginal.data(), t.n_theta, u[0]);
  const float* row = &p.cdf.conditional[i * (t.n_phi + 1)];
  const std::size_t j = cdf_find(row, t.n_phi, u[1]);
  const double pc = double(p.cdf.marginal[i + 1] - p.cdf.marginal[i]) * double(row[j + 1] - row[j]);
  double th, ph;
  if (!(pc > 0) || !cdf_draw(p, u[0], u[1], u[2], u[3], th, ph)) return 0;
  return p.light.radiance(th, ph) * double(t.f[i * t.n_phi + j]) * t.cell_weight(i) / pc;
}

bool draw(const Problem& p, const double u[4], double& th, double& ph) {
  return cdf_draw(p, u[0], u[1], u[2], u[3], th, ph);
}

}  // namespace

EstimatorInfo builtin::cdf_tab() {
  EstimatorInfo e = study_entry(Estimator::CdfTab, "cdf_tab", "table CDF", 0, {estimate, draws::cdf_pdf, draw}, true);
  e.render = path_part(BsdfSampler::TableCdf, false);
  return e;
}

}  // namespace bsdfmix
