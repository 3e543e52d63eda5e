// The stand-in of each slice of a batch: luminance and channel amplitudes on its Gaussians.
#include "sweep/stand_in.hpp"

#include <cmath>

#include "core/error.hpp"

namespace bsdfmix {

std::vector<StandIn> fit_stand_ins(EmEngine& engine, const SliceGrid& grid, const std::vector<StandInSlice>& slices) {
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
      for (int j = 0; j < K; ++j) mass += g.weight[std::size_t(j)] * in_domain_mass(grid.domain, g.mean[2 * j], g.cov[3 * j]);
      si.scale = mass > 0 ? total / mass : total;
    }
    if (colour)
      for (int j = 0; j < K; ++j)
        for (int c = 0; c < 3; ++c) si.rgb[std::size_t(3 * j + c)] = a[std::size_t((c + 1) * K + j)];
  }
  return out;
}

}  // namespace bsdfmix
