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

// How a mixture file stores its per-component arrays (docs/formats.md, "Mixture file",
// "Storage"): padded to [S, Kmax] (as every file before this option) or ragged, one flat
// [sum k, ...] array with a per-slice `offset`; rgb_scale as float64 (as before) or float32.
// Memory always holds the padded arrays in double (rgb_scale) and float (the rest); the
// storage only changes what write_mixture_group writes and what payload_bytes counts.
struct MixtureStorage {
  bool ragged = false;
  bool float32 = false;  // rgb_scale as float32 (weights, means, covariances always are)
  bool operator==(const MixtureStorage& o) const { return ragged == o.ragged && float32 == o.float32; }
};

// "padded", "ragged", "padded_f32" or "ragged_f32"; parse throws InputError naming `where`.
std::string storage_name(const MixtureStorage& s);
MixtureStorage parse_storage(const std::string& name, const std::string& where);

// The mixture file's format version (attribute `format_version`): 2 adds `map`; a file
// without the attribute is version 1, in (theta, phi).
constexpr int kMixtureFormatVersion = 2;

// A slice's uniform share where its file has no `defensive` dataset (files before it).
constexpr double kDefaultDefensive = 0.1;

// Values per component of rgb_copies: kCopies copies x R, G, B.
constexpr std::size_t kCopyValues = std::size_t(mix::kCopies) * 3;

struct MixtureFile {
  MixtureStorage storage;            // as written; read_mixture_file sets what it found
  Domain domain = Domain::Fiber;
  // The plane of the components (docs/formats.md, "Maps"): attribute `map`; a file without
  // it (format_version 1) is in (theta, phi).
  Map map = Map::ThetaPhi;
  bool azimuthal = true;
  std::string table_source = "{}";   // the table's `source` attribute
  std::string fit_settings = "{}";   // JSON: the fit settings that made the file
  std::vector<double> table_theta_o, table_phi_o;  // the table's omega_o axes (for interpolation)
  // Between fitted slices: blend (absent attribute) or displace (docs/formats.md,
  // "Interpolation between slices").
  mix::Interpolation interpolation = mix::Interpolation::Blend;

  std::vector<double> theta_o, phi_o, scale, loglik, l1_rel;  // [S]
  // [S]: each slice's earned uniform share (sweep/earned_share.hpp); add_slice appends 0.1,
  // as a file without the dataset reads.
  std::vector<double> defensive;
  std::vector<std::int32_t> k;                                // [S]
  int kmax = 0;
  std::vector<float> weights;      // [S, kmax]
  std::vector<float> means;        // [S, kmax, 2]
  std::vector<float> covariances;  // [S, kmax, 3]
  // [S, kmax, 3]: per component the integral of each channel (R, G, B) of the integrand,
  // as `scale` is the luminance's (docs/formats.md, "Mixture file"); empty: no colour.
  std::vector<double> rgb_scale;
  // [S, kmax, 4, 3]: the colour copies' amplitudes (the header's copy_of; docs/formats.md,
  // "Colour copies"), all zero on a slice without them; empty: no slice has them.
  std::vector<double> rgb_copies;
  // [S] and [S, 3]: the Lambertian base's share of each slice's mixture and its colour
  // amplitudes (docs/formats.md, "The base"; disk files only); zeros: no base.
  std::vector<double> base, base_rgb;

  std::size_t slices() const { return theta_o.size(); }
  bool has_rgb() const { return !rgb_scale.empty(); }
  bool has_copies() const { return !rgb_copies.empty(); }
  // Appends one slice; pads or widens to kmax as needed. `rgb` (3K, [component][channel])
  // gives its rgb_scale: every slice of a file has it, or none. `copies` (12K,
  // [component][copy][channel]; null or empty: none) its colour copies.
  void add_slice(double theta_o_, double phi_o_, double scale_, double loglik_, double l1_rel_,
                 const std::vector<double>& w, const std::vector<double>& mean, const std::vector<double>& cov,
                 const std::vector<double>* rgb = nullptr, const std::vector<double>* copies = nullptr);
  // Gives the last slice added its base: its share of the mixture (weights and share sum
  // to 1) and its colour amplitudes (rgb may be null).
  void set_base(double share, const double* rgb);
  bool has_base() const;
  // The k used components of slice s as parameter arrays (K, 2K, 3K).
  void slice_params(std::size_t s, std::vector<double>& w, std::vector<double>& mean, std::vector<double>& cov) const;
  // The k used components' rgb_scale of slice s (3K, [component][channel]); empty without colour.
  std::vector<double> slice_rgb(std::size_t s) const;
  // The k used components' colour copies of slice s (12K); empty where it has none.
  std::vector<double> slice_copies(std::size_t s) const;
  // Appends slice s of `from` as it is (components, rgb_scale, per-slice values).
  void add_slice_from(const MixtureFile& from, std::size_t s);
  // This file's header (storage, domain, symmetry, table source, fit settings, omega_o
  // axes) with no slices.
  MixtureFile header_only() const;
  // Components stored: S * kmax padded, sum k ragged.
  std::uint64_t stored_components() const;
  // Bytes of the datasets as the file stores them in `storage` (H5Dget_storage_size of
  // each; with padding, the padding to kmax included): the measure of compression.
  std::uint64_t payload_bytes() const;
};

// Writes group /mixture into an open HDF5 file (`path` names it in errors).
void write_mixture_group(hid_t file, const MixtureFile& m, const std::string& path);

// Writes the file under a temporary name and renames it into place.
void write_mixture_file(const std::string& path, const MixtureFile& m);

// "blend" or "displace"; parse throws InputError naming `where`.
const char* interpolation_name(mix::Interpolation i);
mix::Interpolation parse_interpolation(const std::string& name, const std::string& where);

// Reads and validates a mixture file; throws InputError naming file, dataset and slice.
MixtureFile read_mixture_file(const std::string& path);

// Slice s as the renderer-facing header holds it (prepared): the stored float32 parameters,
// the scale and, with colour, each component's rgb amplitudes.
mix::SliceMixture slice_mixture(const MixtureFile& m, std::size_t s);

// The renderer-facing view of the file (prepared: ready to evaluate and sample).
mix::MixtureSet to_mixture_set(const MixtureFile& m);

}  // namespace bsdfmix
