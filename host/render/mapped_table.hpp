// A full-4D fiber table (no azimuthal symmetry) as a renderer holds a table of gigabytes
// (docs/render.md, "A full-4D table"): the file memory-mapped, never read into memory.
// Each (theta_o, phi_o) slice is one uncompressed HDF5 chunk; its file address comes from
// H5Dget_chunk_info, and f is read through the mapping. f(theta_o, phi_o; theta_i, phi_i):
// bilinear between the 4 slices around (theta_o, phi_o) (theta_o clamps, phi_o wraps), the
// nearest cell in (theta_i, phi_i). All angles in the fiber's reference frame (phi_o and
// phi_i from the same axis), as the table's.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "io/table.hpp"

namespace bsdfmix {
namespace render {

class MappedTable {
 public:
  // Maps `path`; InputError (one line, naming the file) when it is not a fiber table
  // without symmetry, or its `values` are compressed, not float32 little endian, or not
  // chunked one slice per chunk.
  explicit MappedTable(const std::string& path);
  ~MappedTable();
  MappedTable(const MappedTable&) = delete;
  MappedTable& operator=(const MappedTable&) = delete;

  const TableMeta& meta() const { return meta_; }
  // The stored value of one cell, through the mapping.
  float cell(std::size_t t_o, std::size_t p_o, std::size_t t_i, std::size_t p_i) const {
    return slice(t_o * meta_.phi_o.size() + p_o)[t_i * n_phi_i_ + p_i];
  }
  // f (luminance, sr^-1) at omega_o = (theta_o, phi_o), omega_i = (theta, phi); 0 outside
  // theta_i's range.
  double f(double theta_o, double phi_o, double theta, double phi) const;

  std::uint64_t table_bytes() const;       // the `values` cells: n_slices x cells x 4
  std::uint64_t mapped_bytes() const { return len_; }  // the whole file, mapped
  // The mapping's pages resident in this process (/proc/self/smaps Rss); 0 where unknown.
  std::uint64_t resident_bytes() const;

 private:
  const float* slice(std::size_t s) const { return reinterpret_cast<const float*>(base_ + addr_[s]); }
  void read_layout(const std::string& path);

  TableMeta meta_;
  const unsigned char* base_ = nullptr;
  std::size_t len_ = 0;
  std::vector<std::uint64_t> addr_;  // per slice index t_o * n_phi_o + p_o: its chunk's file offset
  std::size_t n_phi_i_ = 0;
  double to0_ = 0, dto_ = 1, po0_ = 0, dpo_ = 1, th0_ = 0, dth_ = 1, ph0_ = 0, dph_ = 1;
};

// The peak resident set of this process (getrusage), bytes.
std::uint64_t peak_rss_bytes();

}  // namespace render
}  // namespace bsdfmix
