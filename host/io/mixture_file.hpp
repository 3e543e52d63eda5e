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

  std::size_t slices() const { return theta_o.size(); }
  // Appends one slice; pads or widens to kmax as needed.
  void add_slice(double theta_o_, double phi_o_, double scale_, double loglik_, double l1_rel_,
                 const std::vector<double>& w, const std::vector<double>& mean, const std::vector<double>& cov);
  // The k used components of slice s as parameter arrays (K, 2K, 3K).
  void slice_params(std::size_t s, std::vector<double>& w, std::vector<double>& mean, std::vector<double>& cov) const;
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

// The renderer-facing view of the file (prepared: ready to evaluate and sample).
mix::MixtureSet to_mixture_set(const MixtureFile& m);

}  // namespace bsdfmix
