// Built with -ffast-math (CMakeLists.txt), which lets GCC call libmvec's vector exp: the
// file holds only this loop, so no other arithmetic is reordered by it.
#include "core/vector_math.hpp"

#include <cmath>

namespace bsdfmix {

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
__attribute__((target_clones("default", "avx2", "arch=x86-64-v4")))
#endif
void exp_in_place(double* x, std::size_t n) {
  for (std::size_t i = 0; i < n; ++i) {
    const double v = x[i];
    // the argument clamped first: a lane past the range takes libmvec's scalar fallback
    const double e = std::exp(v < -708.0 ? -708.0 : v);
    x[i] = v < -708.0 ? 0.0 : e;
  }
}

}  // namespace bsdfmix
