// The stand-in of each slice of a batch: luminance and channel amplitudes on its Gaussians.
#include "sweep/stand_in.hpp"

#include <bsdfmix/mixture.hpp>

#include <cmath>

#include "core/domain.hpp"
#include "core/error.hpp"

namespace bsdfmix {

Gmm colour_copies(const Gmm& gmm) {
  Gmm out;
  const double none[3] = {0, 0, 0};
  for (int j = 0; j < gmm.k(); ++j) {
    mix::Gaussian g;
    g.mu_t = float(gmm.mean[2 * j]);
    g.mu_p = float(gmm.mean[2 * j + 1]);
    g.s_tt = float(gmm.cov[3 * j]);
    g.s_tp = float(gmm.cov[3 * j + 1]);
    g.s_pp = float(gmm.cov[3 * j + 2]);
    for (int m = 0; m < mix::kCopies; ++m) {
      const mix::Gaussian c = mix::copy_of(g, m, none);
      out.weight.push_back(1.0 / (mix::kCopies * gmm.k()));
      out.mean.insert(out.mean.end(), {c.mu_t, wrap_phi(c.mu_p)});
      out.cov.insert(out.cov.end(), {c.s_tt, c.s_tp, c.s_pp});
    }
  }
  return out;
}

namespace {

// The colour copies of the slices whose colour error is above copies_ratio times their
// luminance error (by their fits on the components, `fits`): fitted on R, G, B alone and
// kept where their RGB error is the lower.
void fit_copies(EmEngine& engine, const ChannelSet& set, const std::vector<AmplitudeProblem>& problems,
                const std::vector<AmplitudeFit>& fits, double copies_ratio, const std::vector<std::size_t>& owner,
                std::vector<StandIn>& out) {
  const std::size_t n = set.grid.cells();
  ChannelSet rgb;
  rgb.grid = set.grid;
  rgb.channels = 3;
  std::vector<AmplitudeProblem> todo;
  std::vector<std::size_t> which;  // index into problems
  std::vector<double> base_err;
  for (std::size_t p = 0; p < problems.size(); ++p) {
    const std::vector<double>& v = set.values[problems[p].slice];
    double lum = 0, abs_rgb = 0;
    for (std::size_t i = 0; i < n; ++i) lum += v[i];
    for (std::size_t i = n; i < 4 * n; ++i) abs_rgb += std::abs(v[i]);
    const double err = fits[p].l1[1] + fits[p].l1[2] + fits[p].l1[3];
    if (!(lum > 0) || !(abs_rgb > 0) || !(err / abs_rgb > copies_ratio * fits[p].l1[0] / lum)) continue;
    if (mix::kCopies * problems[p].gmm.k() > kEmMaxK) continue;  // beyond the kernels' largest K
    todo.push_back({rgb.values.size(), colour_copies(problems[p].gmm)});
    rgb.values.emplace_back(v.begin() + long(n), v.end());
    which.push_back(p);
    base_err.push_back(err);
  }
  if (todo.empty()) return;
  const EmEngine::AmpSlices prepared = EmEngine::amp_prepare(rgb);
  const std::vector<AmplitudeFit> copies = fit_amplitudes(
      [&](const std::vector<AmplitudeQuery>& q) { return engine.amplitude_sums(prepared, q); }, rgb, todo);
  for (std::size_t t = 0; t < todo.size(); ++t) {
    const AmplitudeFit& f = copies[t];
    if (!(f.l1[0] + f.l1[1] + f.l1[2] < base_err[t])) continue;  // the components' colour is the better
    StandIn& si = out[owner[which[t]]];
    const int K = problems[which[t]].gmm.k(), KC = mix::kCopies * K;
    si.copies.assign(std::size_t(12 * K), 0.0);
    std::fill(si.rgb.begin(), si.rgb.end(), 0.0);
    for (int j = 0; j < K; ++j)
      for (int m = 0; m < mix::kCopies; ++m)
        for (int c = 0; c < 3; ++c) {
          const double a = f.amp[std::size_t(c * KC + j * mix::kCopies + m)];
          si.copies[std::size_t((j * mix::kCopies + m) * 3 + c)] = a;
          si.rgb[std::size_t(3 * j + c)] += a;
        }
  }
}

}  // namespace

std::vector<StandIn> fit_stand_ins(EmEngine& engine, const SliceGrid& grid, const std::vector<StandInSlice>& slices,
                                   double copies_ratio) {
  const bool colour = !slices.empty() && slices.front().rgb != nullptr;
  const std::size_t n = grid.cells();
  ChannelSet set;
  set.grid = grid;
  set.channels = colour ? 4 : 1;
  std::vector<AmplitudeProblem> problems;
  std::vector<std::size_t> owner;
  std::vector<StandIn> out(slices.size());
  for (std::size_t s = 0; s < slices.size(); ++s) {
    const StandInSlice& sl = slices[s];
    if ((sl.rgb != nullptr) != colour) throw Error("fit_stand_ins: every slice has colour, or none");
    const Gmm& g = *sl.gmm;
    out[s].weight = g.weight;
    if (colour) out[s].rgb.assign(3 * std::size_t(g.k()), 0.0);
    double total = 0;
    for (double w : *sl.luminance) total += w;
    if (!(total > 0)) continue;  // a zero slice: its stand-in is 0
    std::vector<double> v = *sl.luminance;
    if (colour) v.insert(v.end(), sl.rgb->begin(), sl.rgb->end());
    if (v.size() != std::size_t(set.channels) * n) throw Error("fit_stand_ins: a slice does not match the grid");
    problems.push_back({set.values.size(), g});
    owner.push_back(s);
    set.values.push_back(std::move(v));
  }
  if (problems.empty()) return out;
  const EmEngine::AmpSlices prepared = EmEngine::amp_prepare(set);
  const std::vector<AmplitudeFit> fits = fit_amplitudes(
      [&](const std::vector<AmplitudeQuery>& q) { return engine.amplitude_sums(prepared, q); }, set, problems);
  for (std::size_t p = 0; p < problems.size(); ++p) {
    StandIn& si = out[owner[p]];
    const Gmm& g = problems[p].gmm;
    const int K = g.k();
    const std::vector<double>& a = fits[p].amp;
    double sum = 0;
    for (int j = 0; j < K; ++j) sum += a[std::size_t(j)];
    if (sum > 0 && std::isfinite(sum)) {
      si.scale = sum;
      for (int j = 0; j < K; ++j) si.weight[std::size_t(j)] = a[std::size_t(j)] / sum;
    } else {  // no solve: the fitted weights, scaled to the table's in-domain integral
      double total = 0, mass = 0;
      for (std::size_t i = 0; i < n; ++i) total += set.values[problems[p].slice][i];
      for (int j = 0; j < K; ++j) mass += g.weight[std::size_t(j)] * in_domain_mass(grid, g, j);
      si.scale = mass > 0 ? total / mass : total;
    }
    if (colour)
      for (int j = 0; j < K; ++j)
        for (int c = 0; c < 3; ++c) si.rgb[std::size_t(3 * j + c)] = a[std::size_t((c + 1) * K + j)];
  }
  if (colour && copies_ratio >= 0) fit_copies(engine, set, problems, fits, copies_ratio, owner, out);
  return out;
}

}  // namespace bsdfmix
