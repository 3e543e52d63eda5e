// Where the convergence study's files go when the config does not say: the defaults of
// the converge section's output paths, for the converge and charts stages.
#pragma once

#include <string>

#include "config/config.hpp"

namespace bsdfmix {

// The tail-risk CSV of a converge section: tail_csv, else <csv stem>_tail.csv beside csv.
std::string converge_tail_path(const ConvergeSection& c);

// The lighting tail CSV (light_tail_csv, else <csv stem>_light_tail.csv) and the cache of
// the lighting mixtures (light_mixture_dir, else light_mixtures/ beside csv).
std::string converge_light_tail_path(const ConvergeSection& c);
std::string converge_light_mixture_dir(const ConvergeSection& c);

// The mixture file the study samples: converge.mixture, else fit.output; ConfigError if neither.
std::string converge_mixture_path(const Config& config);

}  // namespace bsdfmix
