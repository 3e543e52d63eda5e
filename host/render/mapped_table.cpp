// A full-4D fiber table, memory-mapped: chunk addresses from HDF5, f through the mapping.
#include "render/mapped_table.hpp"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "core/domain.hpp"
#include "core/error.hpp"
#include "io/h5.hpp"

namespace bsdfmix {
namespace render {

namespace {

// A position u on an axis of n points: the lower index and the weight of the upper one; a
// position within 1e-9 of a grid point is that point (exact values at the cells).
void split(double u, std::size_t n, bool wrap, std::size_t& i0, std::size_t& i1, double& w) {
  const double r = std::round(u);
  if (std::abs(u - r) < 1e-9) u = r;
  if (!wrap) u = std::min(std::max(u, 0.0), double(n - 1));
  const double fl = std::floor(u);
  w = u - fl;
  long i = long(fl);
  if (wrap) i = ((i % long(n)) + long(n)) % long(n);
  i0 = std::size_t(i);
  i1 = wrap ? (i0 + 1) % n : std::min(i0 + 1, n - 1);
}

}  // namespace

MappedTable::MappedTable(const std::string& path) {
  {
    const TableReader reader(path);  // the structure, axes and attributes, checked
    meta_ = reader.meta();
  }
  if (meta_.domain != Domain::Fiber)
    throw InputError(path + ": the full-4D render needs a fiber table (domain fiber)");
  if (meta_.azimuthal)
    throw InputError(path + ": the full-4D render needs a table without symmetry (this one is azimuthal)");
  read_layout(path);
  const int fd = ::open(path.c_str(), O_RDONLY);
  if (fd < 0) throw InputError(path + ": cannot open for mapping");
  struct stat st {};
  ::fstat(fd, &st);
  len_ = std::size_t(st.st_size);
  void* p = ::mmap(nullptr, len_, PROT_READ, MAP_SHARED, fd, 0);
  ::close(fd);
  if (p == MAP_FAILED) throw InputError(path + ": mmap failed");
  base_ = static_cast<const unsigned char*>(p);
  const std::uint64_t slice_bytes = meta_.cells_per_slice() * sizeof(float);
  for (std::size_t s = 0; s < addr_.size(); ++s)
    if (addr_[s] + slice_bytes > len_)
      throw InputError(path + ": slice " + std::to_string(s) + " lies past the file's end");
  n_phi_i_ = meta_.phi_i.size();
  to0_ = meta_.theta_o.front();
  // the steps as TableBsdf's lookup takes them (core/domain.hpp axis_step)
  dto_ = axis_step(meta_.theta_o);
  po0_ = meta_.phi_o.front();
  dpo_ = axis_step(meta_.phi_o);
  dth_ = axis_step(meta_.theta_i);
  dph_ = axis_step(meta_.phi_i);
  th0_ = meta_.theta_i.front() - dth_ / 2;
  ph0_ = meta_.phi_i.front() - dph_ / 2;
}

void MappedTable::read_layout(const std::string& path) {
  const h5::Handle file = h5::open_file(path);
  const h5::Handle group = h5::open_group(file.get(), "table", path);
  const std::string where = path + ": /table/values";
  const h5::Handle values = h5::open_dataset(group.get(), "values", path + ": /table");
  const h5::Handle type(H5Dget_type(values.get()));
  if (H5Tequal(type.get(), H5T_IEEE_F32LE) <= 0)
    throw InputError(where + ": the mapped render needs float32 little endian");
  const h5::Handle dcpl(H5Dget_create_plist(values.get()));
  if (H5Pget_layout(dcpl.get()) != H5D_CHUNKED) throw InputError(where + ": not chunked one slice per chunk");
  if (H5Pget_nfilters(dcpl.get()) != 0)
    throw InputError(where + ": compressed (filters on the chunks); the mapped render needs an uncompressed table");
  hsize_t chunk[4] = {0, 0, 0, 0};
  if (H5Pget_chunk(dcpl.get(), 4, chunk) != 4 || chunk[0] != 1 || chunk[1] != 1 || chunk[2] != meta_.theta_i.size() ||
      chunk[3] != meta_.phi_i.size())
    throw InputError(where + ": not chunked one slice per chunk");
  const std::size_t np = meta_.phi_o.size();
  addr_.assign(meta_.n_slices(), ~std::uint64_t(0));
  // by coordinate: a B-tree lookup per slice (H5Dget_chunk_info by index walks the tree
  // from its start each time, quadratic in the slices)
  for (std::size_t t = 0; t < meta_.theta_o.size(); ++t)
    for (std::size_t p = 0; p < np; ++p) {
      const hsize_t off[4] = {t, p, 0, 0};
      unsigned mask = 0;
      haddr_t addr = HADDR_UNDEF;
      hsize_t size = 0;
      if (H5Dget_chunk_info_by_coord(values.get(), off, &mask, &addr, &size) < 0 || addr == HADDR_UNDEF) continue;
      if (size != meta_.cells_per_slice() * sizeof(float))
        throw InputError(where + ": a chunk's size is not a slice's");
      addr_[t * np + p] = addr;
    }
  for (std::size_t s = 0; s < addr_.size(); ++s)
    if (addr_[s] == ~std::uint64_t(0)) throw InputError(where + ": slice " + std::to_string(s) + " was never written");
}

MappedTable::~MappedTable() {
  if (base_) ::munmap(const_cast<unsigned char*>(base_), len_);
}

double MappedTable::f(double theta_o, double phi_o, double theta, double phi) const {
  const double fi = std::floor((theta - th0_) / dth_);
  const std::size_t nt = meta_.theta_i.size(), np = meta_.phi_i.size();
  if (!(fi >= 0) || fi >= double(nt)) return 0.0;
  long j = long(std::floor((phi - ph0_) / dph_)) % long(np);
  if (j < 0) j += long(np);
  const std::size_t c = std::size_t(fi) * np + std::size_t(j);
  std::size_t t0, t1, p0, p1;
  double wt, wp;
  split((theta_o - to0_) / dto_, meta_.theta_o.size(), false, t0, t1, wt);
  split((wrap_phi(phi_o) - po0_) / dpo_, meta_.phi_o.size(), true, p0, p1, wp);
  const std::size_t npo = meta_.phi_o.size();
  double out = 0;
  const std::size_t ts[2] = {t0, t1}, ps[2] = {p0, p1};
  const double wts[2] = {1 - wt, wt}, wps[2] = {1 - wp, wp};
  for (int a = 0; a < 2; ++a)
    for (int b = 0; b < 2; ++b)
      if (wts[a] > 0 && wps[b] > 0) out += wts[a] * wps[b] * double(slice(ts[a] * npo + ps[b])[c]);
  return out;
}

std::uint64_t MappedTable::table_bytes() const {
  return std::uint64_t(meta_.n_slices()) * meta_.cells_per_slice() * sizeof(float);
}

std::uint64_t MappedTable::resident_bytes() const {
  std::ifstream in("/proc/self/smaps");
  char head[32];
  std::snprintf(head, sizeof head, "%lx-", static_cast<unsigned long>(reinterpret_cast<std::uintptr_t>(base_)));
  std::string line;
  bool inside = false;
  while (std::getline(in, line)) {
    if (line.rfind(head, 0) == 0) inside = true;
    else if (inside && line.rfind("Rss:", 0) == 0) {
      std::istringstream s(line.substr(4));
      std::uint64_t kib = 0;
      s >> kib;
      return kib * 1024;
    }
  }
  return 0;
}

std::uint64_t peak_rss_bytes() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return std::uint64_t(u.ru_maxrss) * 1024;
}

}  // namespace render
}  // namespace bsdfmix
