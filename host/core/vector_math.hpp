// exp over arrays of doubles, vectorized: the host's evaluations of a mixture over a
// slice's cells (sweep/fit_error.cpp, fit/smem.cpp, fit/gmm.cpp) take one exp per cell and
// component, which glibc's scalar exp made a fifth of a large fit's time.
#pragma once

#include <cstddef>

namespace bsdfmix {

// x[i] = exp(x[i]) for i < n, and 0 where x[i] < -708 (below exp's normal range; libm's
// slow path). Vectorized by glibc's libmvec at the CPU's widest vectors (AVX-512, AVX2 or
// SSE2, chosen at load time on x86-64): within 4 ulp of std::exp.
void exp_in_place(double* x, std::size_t n);

}  // namespace bsdfmix
