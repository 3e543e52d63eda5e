// The HDF5 table file (group /table; docs/formats.md, "Table file"), read and written
// one omega_o slice at a time.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/domain.hpp"

namespace bsdfmix {

struct TableMeta {
  Domain domain = Domain::Fiber;
  bool azimuthal = true;  // symmetry "azimuthal": n_phi_o = 1, phi_o = [0]
  std::vector<double> theta_o, phi_o, theta_i, phi_i;
  std::string source = "{}";  // JSON text: generator or importer and its parameters
  bool rgb = false;           // an `rgb` channel [..., 3] beside `values`
  // With rgb: the cells with a negative R, G or B, as the writer counted them (attribute
  // `negative_rgb_cells`); -1 where the file does not record it.
  std::int64_t negative_rgb_cells = -1;

  std::size_t n_slices() const { return theta_o.size() * phi_o.size(); }
  std::size_t cells_per_slice() const { return theta_i.size() * phi_i.size(); }
  std::size_t slice_index(std::size_t t_o, std::size_t p_o) const { return t_o * phi_o.size() + p_o; }
};

// Checks the axes of `meta` against the domain (uniform, inside it, phi_i a full
// period, phi_o = [0] with azimuthal symmetry); throws InputError naming `where`.
void validate_meta(const TableMeta& meta, const std::string& where);

// A table meta with the default grid of a domain: theta_o, theta_i and phi_i cell
// centers splitting their ranges evenly, phi_o = [0] (azimuthal) or n_phi_o centers.
TableMeta make_grid(Domain domain, std::size_t n_theta_o, std::size_t n_phi_o, std::size_t n_theta_i,
                    std::size_t n_phi_i, bool azimuthal);

// How many of `cells` R, G, B triples (rgb[3 i .. 3 i + 2]) hold a negative channel: what
// TableWriter records as `negative_rgb_cells`.
std::size_t count_negative_rgb(const float* rgb, std::size_t cells);

// Reads a table; the constructor checks structure, shapes, axes and attributes,
// each slice read checks its cells (NaN, Inf, negative), naming slice and cell.
class TableReader {
 public:
  explicit TableReader(const std::string& path);
  // The table file `path` from its bytes, already in memory (load_table): nothing more
  // is read from the disk.
  TableReader(const std::string& path, const std::string& bytes);
  ~TableReader();
  TableReader(TableReader&&) noexcept;
  TableReader& operator=(TableReader&&) noexcept;

  const std::string& path() const;
  const TableMeta& meta() const;
  // f of slice (t_o, p_o), row-major [theta_i][phi_i]; reads only that slice.
  std::vector<float> read_slice(std::size_t t_o, std::size_t p_o) const;
  // The rgb channel of the slice, [theta_i][phi_i][3]; InputError when absent.
  std::vector<float> read_slice_rgb(std::size_t t_o, std::size_t p_o) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// A table file read once: the hash of its bytes (hash_file's value) and a reader over
// them, in memory.
struct LoadedTable {
  std::uint64_t file_hash = 0;
  TableReader reader;
};
LoadedTable load_table(const std::string& path);

// Writes a table slice by slice under a temporary name; commit() checks that
// every slice was written and renames it into place. Without commit() nothing
// is left behind. `deflate` 0 stores the datasets uncompressed; 1..9 compresses each
// slice chunk with HDF5's shuffle and deflate filters at that level (IoError when this
// HDF5 has no deflate filter). Readers decompress transparently.
class TableWriter {
 public:
  TableWriter(const std::string& path, const TableMeta& meta, int deflate = 0);
  ~TableWriter();
  void write_slice(std::size_t t_o, std::size_t p_o, const float* values, const float* rgb = nullptr);
  void commit();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Writes a whole in-memory table ([n_theta_o][n_phi_o][n_theta_i][n_phi_i]) at once.
void write_table(const std::string& path, const TableMeta& meta, const std::vector<float>& values);

}  // namespace bsdfmix
