// examples/cpp/albedo.cpp
// The shortest complete use of a mixture file. Loads it (bsdfmix/mixture_h5.hpp),
// samples it at theta_o = 37 deg and estimates the albedo per channel by Monte Carlo:
//   g++ -std=c++17 -O2 -I include examples/cpp/albedo.cpp $(pkg-config --cflags --libs hdf5) -o albedo
//   ./albedo MIXTURE.h5
#include <bsdfmix/mixture_h5.hpp>

#include <cmath>
#include <cstdio>

namespace mix = bsdfmix::mix;

int main(int argc, char** argv) try {
  const mix::MixtureSet set = mix::load_mixture_h5(argc > 1 ? argv[1] : "mixture.h5");
  const double theta_o = 37 * mix::kPi / 180, phi_o = 0;  // the view direction, radians
  const bool hemisphere = set.domain == mix::Domain::Hemisphere;
  const int n = 1 << 16;
  double albedo[3] = {0, 0, 0};
  for (int i = 0; i < n; ++i) {
    // sample i of `bsdfmix sample --seed 1`
    const mix::Sample s = set.sample_counter(theta_o, phi_o, 1, mix::kSampleStream, std::uint64_t(i));
    if (!s.valid) continue;  // outside the domain: contributes 0
    double f[3];
    set.eval_rgb(theta_o, phi_o, s.theta, s.phi, f);
    const double w = (hemisphere ? std::cos(s.theta) : 1.0) / s.pdf_omega;
    for (int c = 0; c < 3; ++c) albedo[c] += f[c] * w / n;
  }
  std::printf("albedo at theta_o = 37 deg: R %.4f, G %.4f, B %.4f\n", albedo[0], albedo[1], albedo[2]);
  return 0;
} catch (const std::exception& e) {
  std::fprintf(stderr, "%s\n", e.what());
  return 1;
}
