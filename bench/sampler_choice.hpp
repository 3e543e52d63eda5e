// `bsdfmix recommend MIXTURE.h5 TABLE.h5` (docs/sampling.md, "Choosing a sampler"): a
// short measurement of the candidate samplers on one material, and the one to take.
// Each candidate estimates the integral of L_i f cos(theta_i) at a few view elevations
// (cell centers of [0, theta_max]); its figure is the relative variance per sample,
// variance / integral^2, the median over the views. The candidate with the least figure
// is recommended, for BSDF-only sampling (constant light) and, given a scene, with
// lighting. f is the RGL file's evaluation with --rgl, else the table (as in `bench
// sampling`, bench/sampling_peers.hpp, whose weights it uses).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "bench/sampling_peers.hpp"

namespace bsdfmix::bench {

struct SamplerChoiceOptions {
  std::string mixture, table, rgl, scene;  // rgl, scene: "" for none
  int views = 5;
  std::uint64_t samples = 131072;
  double theta_max_deg = 85;
  std::uint64_t seed = 1;
  int quadrature = 256;  // the RGL integral's cells in sin^2 theta (x 2 in phi)
  double light_fraction = 0.5;
};

// One candidate under one lighting.
struct SamplerFigure {
  std::string lighting;  // constant, or the scene's name
  std::string sampler;   // the estimator's name (docs/sampling.md)
  std::string share;     // mis_tab's uniform share: "0.1" or "earned"; "" for the others
  std::vector<double> relvar;  // per view
  double median = 0, max = 0;  // over the views
  double vs_reference = 0;     // the median over the views of relvar / the reference's
  std::uint64_t bytes = 0;     // what the sampler keeps: the packed mixture, the table, the file
  bool recommended = false;
};

struct SamplerChoice {
  std::vector<double> views_deg;
  std::uint64_t samples = 0;           // per candidate and view
  std::vector<std::string> lightings;  // constant first, then the scene
  std::vector<std::string> references;  // per lighting: the sampler the figures are relative to
  std::vector<SamplerFigure> figures;   // lighting by lighting
  double seconds = 0;
};

SamplerChoice choose_sampler(const SamplerChoiceOptions& o);

// The candidate with the least median relative variance among `figures` of `lighting`
// (ties: the first); -1 when there is none.
int least_variance(const std::vector<SamplerFigure>& figures, const std::string& lighting);

// One row per figure (docs/formats.md, "recommend CSV").
std::string sampler_choice_csv(const SamplerChoice& c, const std::string& material);
// The printed recommendation: a line per lighting, then the table of figures.
std::string sampler_choice_text(const SamplerChoice& c, const std::string& material);

}  // namespace bsdfmix::bench
