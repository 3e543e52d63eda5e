// Slices whose weights are known mixtures: for tests and the benchmark.
#pragma once

#include <cstdint>
#include <vector>

#include "fit/gmm.hpp"
#include "fit/slices.hpp"

namespace bsdfmix {

// The weights of a slice whose density is `gmm`: gmm_density at every cell center
// (row-major [theta][phi]).
std::vector<double> mixture_weights(const SliceGrid& grid, const Gmm& gmm);

// A fiber-like slice mixture with `lobes` components, deterministic for `seed`:
// a narrow specular-like lobe, broader transmission-like lobes spread in phi
// (one of them across phi = +-pi), all inside the theta range of `domain`.
Gmm synthetic_lobes(Domain domain, int lobes, std::uint64_t seed);

}  // namespace bsdfmix
