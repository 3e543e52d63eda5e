// A 2D Gaussian of the header from its weight, mean, standard deviations and correlation
// coefficient, shared by the sampler tests (not prepared: SliceMixture::prepare or
// Gaussian::prepare derives the rest).
#pragma once

#include <bsdfmix/mixture.hpp>

namespace bsdfmix::test {

inline mix::Gaussian gaussian(double w, double mt, double mp, double st, double sp, double rho) {
  mix::Gaussian g;
  g.weight = w;
  g.mu_t = mt;
  g.mu_p = mp;
  g.s_tt = st * st;
  g.s_tp = rho * st * sp;
  g.s_pp = sp * sp;
  return g;
}

}  // namespace bsdfmix::test
