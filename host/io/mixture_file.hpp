// The HDF5 mixture file (group /mixture; docs/formats.md, "Mixture file"): S fitted
// slices, each a 2D Gaussian mixture over (theta_i, phi_i), written atomically and
// validated on read.
#pragma once

#include <bsdfmix/mixture.hpp>
#include <hdf5.h>

#include <cstdint>
#include <string>
#include <vector>

#include "core/domain.hpp"

namespace bsdfmix {

struct MixtureFile {
  Domain domain = Domain::Fiber;
  bool azimuthal = true;
  std::string table_source = "{}";   // the table's `source` attribute
  std::string fit_settings = "{}";   // JSON: the fit settings that made the file
  std::vector<double> table_theta_o, table_phi_o;  // the table's omega_o axes (for interpolation)

  std::vector<double> theta_o, phi_o, scale, loglik, l1_rel;  // [S]
  std::vector<std::int32_t> k;                                // [S]
  int kmax = 0;
  std::vector<float> weights;      // [S, kmax]
  std::vector<float> means;        // [S, kmax, 2]
  std::vector<float> covariances;  // [S, kmax, 3]
  // [S, kmax, 3]: per component the integral of each channel (R, G, B) of the integrand,
  // as `scale` is the luminance's (docs/formats.md, "Mixture file"); empty: no colour.
  std::vector<double> rgb_scale;

  std::size_t slices() const { return theta_o.size(); }
  bool has_rgb() const { return !rgb_scale.empty(); }
  // Appends one slice; pads or widens to kmax as needed. `rgb` (3K, [component][channel])
  // gives its rgb_scale: every slice of a file has it, or none.
  void add_slice(double theta_o_, double phi_o_, double scale_, double loglik_, double l1_rel_,
                 const std::vector<double>& w, const std::vector<double>& mean, const std::vector<double>& cov,
                 const std::vector<double>* rgb = nullptr);
  // The k used components of slice s as parameter arrays (K, 2K, 3K).
  void slice_params(std::size_t s, std::vector<double>& w, std::vector<double>& mean, std::vector<double>& cov) const;
  // The k used components' rgb_scale of slice s (3K, [component][channel]); empty without colour.
  std::vector<double> slice_rgb(std::size_t s) const;
  // Bytes of the datasets as the file stores them (H5Dget_storage_size of each),
  // padding to kmax included: the measure of compression.
  std::uint64_t payload_bytes() const;
};

// Writes group /mixture into an open HDF5 file (`path` names it in errors).
void write_mixture_group(hid_t file, const MixtureFile& m, const std::string& path);

// Writes the file under a temporary name and renames it into place.
void write_mixture_file(const std::string& path, const MixtureFile& m);

// Reads and validates a mixture file; throws InputError naming file, dataset and slice.
MixtureFile read_mixture_file(const std::string& path);

// Slice s as the renderer-facing header holds it (prepared): the stored float32 parameters,
// the scale and, with colour, each component's rgb amplitudes.
mix::SliceMixture slice_mixture(const MixtureFile& m, std::size_t s);

// The renderer-facing view of the file (prepared: ready to evaluate and sample).
mix::MixtureSet to_mixture_set(const MixtureFile& m);

}  // namespace bsdfmix
