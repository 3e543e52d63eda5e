// The parts of a mixture file read beside its slices (io/mixture_file.cpp's reader).
#pragma once

#include <hdf5.h>

#include <string>
#include <vector>

#include "io/mixture_file.hpp"

namespace bsdfmix {

// The domain, the format version and the map (a file without `map` is in (theta, phi)).
void read_mixture_plane(hid_t id, const std::string& where, MixtureFile& m);

// The optional base (docs/formats.md, "The base"): zeros when absent. After theta_o and
// the map are read.
void read_mixture_base(hid_t id, const std::string& where, MixtureFile& m);

// Each slice's uniform share, in [0, 1) (docs/formats.md, `defensive`); files written
// before it: 0.1 for every slice.
std::vector<double> read_mixture_defensive(hid_t id, const std::string& where, std::size_t S);

}  // namespace bsdfmix
