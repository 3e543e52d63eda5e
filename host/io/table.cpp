// The HDF5 table file, read and written one omega_o slice at a time.
#include "io/table.hpp"

#include <cmath>
#include <sstream>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "core/file_errors.hpp"
#include "core/format.hpp"
#include "core/hash.hpp"
#include "io/h5.hpp"

namespace bsdfmix {

namespace {

std::string fmt(double v) { return format_number(v, "%.6g"); }

// Uniform spacing within a relative tolerance; returns the step.
double check_uniform(const std::vector<double>& c, const std::string& where, const std::string& name) {
  if (c.empty()) throw InputError(where + ": axis " + name + " is empty");
  for (std::size_t i = 0; i < c.size(); ++i)
    if (!std::isfinite(c[i]))
      throw InputError(where + ": axis " + name + " cell " + std::to_string(i) + " is not finite");
  if (c.size() == 1) return 0.0;
  const double step = axis_step(c);
  if (!(step > 0)) throw InputError(where + ": axis " + name + " is not increasing");
  for (std::size_t i = 1; i < c.size(); ++i) {
    const double d = c[i] - c[i - 1];
    if (std::abs(d - step) > 1e-6 * step + 1e-12)
      throw InputError(where + ": axis " + name + " is not uniformly spaced (cells " +
                       std::to_string(i - 1) + ".." + std::to_string(i) + " differ by " + fmt(d) +
                       ", expected " + fmt(step) + ")");
  }
  return step;
}

void check_inside(const std::vector<double>& c, double step, double lo, double hi,
                  const std::string& where, const std::string& name) {
  const double eps = 1e-9;
  for (std::size_t i = 0; i < c.size(); ++i)
    if (c[i] - step / 2 < lo - eps || c[i] + step / 2 > hi + eps)
      throw InputError(where + ": axis " + name + " cell " + std::to_string(i) + " (center " +
                       fmt(c[i]) + ") lies outside the domain [" + fmt(lo) + ", " + fmt(hi) + "]");
}

void check_full_period(const std::vector<double>& c, double step, const std::string& where,
                       const std::string& name) {
  if (std::abs(step * static_cast<double>(c.size()) - 2 * kPi) > 1e-6)
    throw InputError(where + ": axis " + name + " must cover the full period [-pi, pi) (" +
                     std::to_string(c.size()) + " cells of " + fmt(step) + " rad cover " +
                     fmt(step * static_cast<double>(c.size())) + ")");
}

std::string slice_name(std::size_t t_o, std::size_t p_o) {
  return "slice (theta_o " + std::to_string(t_o) + ", phi_o " + std::to_string(p_o) + ")";
}

}  // namespace

void validate_meta(const TableMeta& m, const std::string& where) {
  const double tlo = theta_lo(m.domain), thi = theta_hi(m.domain);
  const double st_o = check_uniform(m.theta_o, where, "theta_o");
  check_inside(m.theta_o, 0.0, tlo, thi, where, "theta_o");
  (void)st_o;
  if (m.theta_i.size() < 2) throw InputError(where + ": axis theta_i needs at least 2 cells");
  if (m.phi_i.size() < 2) throw InputError(where + ": axis phi_i needs at least 2 cells");
  const double st_i = check_uniform(m.theta_i, where, "theta_i");
  check_inside(m.theta_i, st_i, tlo, thi, where, "theta_i");
  const double sp_i = check_uniform(m.phi_i, where, "phi_i");
  check_inside(m.phi_i, sp_i, -kPi, kPi, where, "phi_i");
  check_full_period(m.phi_i, sp_i, where, "phi_i");
  if (m.azimuthal) {
    if (m.phi_o.size() != 1 || m.phi_o[0] != 0.0)
      throw InputError(where + ": symmetry 'azimuthal' requires phi_o = [0] (found " +
                       std::to_string(m.phi_o.size()) + " value(s))");
  } else {
    const double sp_o = check_uniform(m.phi_o, where, "phi_o");
    if (m.phi_o.size() > 1) {
      check_inside(m.phi_o, sp_o, -kPi, kPi, where, "phi_o");
      check_full_period(m.phi_o, sp_o, where, "phi_o");
    }
  }
}

TableMeta make_grid(Domain domain, std::size_t n_theta_o, std::size_t n_phi_o, std::size_t n_theta_i,
                    std::size_t n_phi_i, bool azimuthal) {
  TableMeta m;
  m.domain = domain;
  m.azimuthal = azimuthal;
  m.theta_o = uniform_centers(theta_lo(domain), theta_hi(domain), n_theta_o);
  m.phi_o = azimuthal ? std::vector<double>{0.0} : uniform_centers(-kPi, kPi, n_phi_o);
  m.theta_i = uniform_centers(theta_lo(domain), theta_hi(domain), n_theta_i);
  m.phi_i = uniform_centers(-kPi, kPi, n_phi_i);
  return m;
}

// ---------------------------------------------------------------- reader

struct TableReader::Impl {
  std::string path;
  TableMeta meta;
  h5::Handle file, group, values, rgb;
  // Checks the open file's structure, shapes, axes and attributes; reads the meta.
  void open();
};

TableReader::TableReader(const std::string& path) : impl_(std::make_unique<Impl>()) {
  impl_->path = path;
  impl_->file = h5::open_file(path);
  impl_->open();
}

TableReader::TableReader(const std::string& path, const std::string& bytes) : impl_(std::make_unique<Impl>()) {
  impl_->path = path;
  impl_->file = h5::open_image(path, bytes);
  impl_->open();
}

void TableReader::Impl::open() {
  Impl& im = *this;
  im.group = h5::open_group(im.file.get(), "table", path);
  const std::string where = path + ": /table";
  hid_t g = im.group.get();
  TableMeta& m = im.meta;
  m.domain = parse_domain(h5::read_string_attr(g, "domain", where), where + " attribute 'domain'");
  const std::string sym = h5::read_string_attr(g, "symmetry", where);
  if (sym == "azimuthal") m.azimuthal = true;
  else if (sym == "none") m.azimuthal = false;
  else throw InputError(where + ": unknown symmetry '" + sym + "' (expected none or azimuthal)");
  m.source = h5::read_string_attr(g, "source", where);
  if (h5::has_attr(g, "negative_rgb_cells")) {
    const std::string n = h5::read_string_attr(g, "negative_rgb_cells", where);
    if (n.empty() || n.find_first_not_of("0123456789") != std::string::npos || n.size() > 18)
      throw InputError(where + ": attribute 'negative_rgb_cells' is '" + n + "', not a count of cells");
    m.negative_rgb_cells = std::stoll(n);
  }
  m.theta_o = h5::read_doubles(g, "theta_o", where);
  m.phi_o = h5::read_doubles(g, "phi_o", where);
  m.theta_i = h5::read_doubles(g, "theta_i", where);
  m.phi_i = h5::read_doubles(g, "phi_i", where);
  validate_meta(m, path);

  im.values = h5::open_dataset(g, "values", where);
  {
    h5::Handle type(H5Dget_type(im.values.get()));
    if (H5Tget_class(type.get()) != H5T_FLOAT)
      throw InputError(where + "/values: must be floating point");
  }
  const auto dims = h5::shape(im.values.get());
  const std::vector<hsize_t> want = {m.theta_o.size(), m.phi_o.size(), m.theta_i.size(), m.phi_i.size()};
  auto dims_text = [](const std::vector<hsize_t>& d) {
    std::ostringstream s;
    s << "[";
    for (std::size_t i = 0; i < d.size(); ++i) s << (i ? ", " : "") << d[i];
    s << "]";
    return s.str();
  };
  if (dims.size() != 4)
    throw InputError(where + "/values: rank " + std::to_string(dims.size()) +
                     ", expected 4 [n_theta_o, n_phi_o, n_theta_i, n_phi_i]");
  if (dims != want)
    throw InputError(where + "/values: shape " + dims_text(dims) + " does not match the axes " +
                     dims_text(want));
  if (h5::exists(g, "rgb")) {
    im.rgb = h5::open_dataset(g, "rgb", where);
    auto rdims = h5::shape(im.rgb.get());
    auto rwant = want;
    rwant.push_back(3);
    if (rdims != rwant)
      throw InputError(where + "/rgb: shape " + dims_text(rdims) + ", expected " + dims_text(rwant));
    m.rgb = true;
  }
}

LoadedTable load_table(const std::string& path) {
  const std::optional<std::string> bytes = read_text(path);
  if (!bytes) require_readable(path);
  if (!bytes) throw InputError(path + ": cannot read it");
  return LoadedTable{hash_file_bytes(*bytes), TableReader(path, *bytes)};
}

TableReader::~TableReader() = default;
TableReader::TableReader(TableReader&&) noexcept = default;
TableReader& TableReader::operator=(TableReader&&) noexcept = default;

const std::string& TableReader::path() const { return impl_->path; }
const TableMeta& TableReader::meta() const { return impl_->meta; }

namespace {
std::vector<float> read_hyperslab(hid_t dataset, const std::vector<hsize_t>& start,
                                  const std::vector<hsize_t>& count, const std::string& where) {
  h5::Handle file_space(H5Dget_space(dataset));
  hsize_t n = 1;
  for (hsize_t c : count) n *= c;
  std::vector<float> out(n);
  if (H5Sselect_hyperslab(file_space.get(), H5S_SELECT_SET, start.data(), nullptr, count.data(), nullptr) < 0)
    throw InputError(where + ": cannot select slice");
  h5::Handle mem_space(H5Screate_simple(1, &n, nullptr));
  if (H5Dread(dataset, H5T_NATIVE_FLOAT, mem_space.get(), file_space.get(), H5P_DEFAULT, out.data()) < 0)
    throw InputError(where + ": cannot read (corrupt or truncated file)");
  return out;
}
}  // namespace

std::vector<float> TableReader::read_slice(std::size_t t_o, std::size_t p_o) const {
  const TableMeta& m = impl_->meta;
  if (t_o >= m.theta_o.size() || p_o >= m.phi_o.size())
    throw InputError(impl_->path + ": " + slice_name(t_o, p_o) + " out of range");
  const std::string where = impl_->path + ": /table/values " + slice_name(t_o, p_o);
  auto v = read_hyperslab(impl_->values.get(), {t_o, p_o, 0, 0}, {1, 1, m.theta_i.size(), m.phi_i.size()},
                          where);
  const std::size_t np = m.phi_i.size();
  for (std::size_t k = 0; k < v.size(); ++k) {
    const float x = v[k];
    if (!std::isfinite(x) || x < 0.0f) {
      const char* what = std::isnan(x) ? "NaN" : std::isinf(x) ? (x > 0 ? "Inf" : "-Inf") : "negative value";
      throw InputError(where + " cell (theta_i " + std::to_string(k / np) + ", phi_i " +
                       std::to_string(k % np) + "): " + what + (x < 0.0f && std::isfinite(x) ? " " + fmt(x) : ""));
    }
  }
  return v;
}

std::vector<float> TableReader::read_slice_rgb(std::size_t t_o, std::size_t p_o) const {
  const TableMeta& m = impl_->meta;
  if (!m.rgb) throw InputError(impl_->path + ": /table has no rgb channel");
  return read_hyperslab(impl_->rgb.get(), {t_o, p_o, 0, 0, 0},
                        {1, 1, m.theta_i.size(), m.phi_i.size(), 3},
                        impl_->path + ": /table/rgb " + slice_name(t_o, p_o));
}

// ---------------------------------------------------------------- writer

std::size_t count_negative_rgb(const float* rgb, std::size_t cells) {
  std::size_t n = 0;
  for (std::size_t i = 0; i < cells; ++i) n += rgb[3 * i] < 0 || rgb[3 * i + 1] < 0 || rgb[3 * i + 2] < 0;
  return n;
}

struct TableWriter::Impl {
  std::string path;
  TableMeta meta;
  std::unique_ptr<AtomicOutput> out;
  h5::Handle file, group, values, rgb;
  std::vector<bool> written;
  std::vector<std::uint64_t> negative_rgb;  // per slice, its cells with a negative R, G or B
};

TableWriter::TableWriter(const std::string& path, const TableMeta& meta, int deflate)
    : impl_(std::make_unique<Impl>()) {
  Impl& im = *impl_;
  validate_meta(meta, path);
  if (deflate < 0 || deflate > 9) throw IoError(path + ": deflate level must be in [0, 9]");
  if (deflate > 0 && H5Zfilter_avail(H5Z_FILTER_DEFLATE) <= 0)
    throw IoError(path + ": this HDF5 library has no deflate filter (write with deflate level 0)");
  im.path = path;
  im.meta = meta;
  const std::uint64_t bytes = std::uint64_t(meta.n_slices()) * meta.cells_per_slice() * 4 * (meta.rgb ? 4 : 1);
  prepare_output(path, bytes + (1u << 20));
  im.out = std::make_unique<AtomicOutput>(path);
  im.file = h5::create_file(im.out->temp_path());
  im.group = h5::create_group(im.file.get(), "table", path);
  hid_t g = im.group.get();
  const std::string where = path + ": /table";
  h5::write_doubles(g, "theta_o", {meta.theta_o.size()}, meta.theta_o.data(), where);
  h5::write_doubles(g, "phi_o", {meta.phi_o.size()}, meta.phi_o.data(), where);
  h5::write_doubles(g, "theta_i", {meta.theta_i.size()}, meta.theta_i.data(), where);
  h5::write_doubles(g, "phi_i", {meta.phi_i.size()}, meta.phi_i.data(), where);
  h5::write_string_attr(g, "domain", domain_name(meta.domain), where);
  h5::write_string_attr(g, "symmetry", meta.azimuthal ? "azimuthal" : "none", where);
  h5::write_string_attr(g, "source", meta.source, where);

  auto make = [&](const char* name, std::vector<hsize_t> dims) {
    std::vector<hsize_t> chunk = dims;
    chunk[0] = chunk[1] = 1;
    h5::Handle space(H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr));
    h5::Handle dcpl(H5Pcreate(H5P_DATASET_CREATE));
    H5Pset_chunk(dcpl.get(), static_cast<int>(chunk.size()), chunk.data());
    if (deflate > 0 && (H5Pset_shuffle(dcpl.get()) < 0 || H5Pset_deflate(dcpl.get(), unsigned(deflate)) < 0))
      throw IoError(where + ": cannot set the compression of dataset " + name);
    h5::Handle d(H5Dcreate2(g, name, H5T_IEEE_F32LE, space.get(), H5P_DEFAULT, dcpl.get(), H5P_DEFAULT));
    if (!d.valid()) throw IoError(where + ": cannot create dataset " + name);
    return d;
  };
  std::vector<hsize_t> dims = {meta.theta_o.size(), meta.phi_o.size(), meta.theta_i.size(), meta.phi_i.size()};
  im.values = make("values", dims);
  if (meta.rgb) {
    dims.push_back(3);
    im.rgb = make("rgb", dims);
  }
  im.written.assign(meta.n_slices(), false);
  im.negative_rgb.assign(meta.n_slices(), 0);
}

TableWriter::~TableWriter() = default;

void TableWriter::write_slice(std::size_t t_o, std::size_t p_o, const float* values, const float* rgb) {
  Impl& im = *impl_;
  const TableMeta& m = im.meta;
  if (t_o >= m.theta_o.size() || p_o >= m.phi_o.size())
    throw IoError(im.path + ": " + slice_name(t_o, p_o) + " out of range");
  auto put = [&](hid_t d, const float* data, bool with_rgb) {
    std::vector<hsize_t> start = {t_o, p_o, 0, 0}, count = {1, 1, m.theta_i.size(), m.phi_i.size()};
    if (with_rgb) {
      start.push_back(0);
      count.push_back(3);
    }
    hsize_t n = 1;
    for (hsize_t c : count) n *= c;
    h5::Handle fs(H5Dget_space(d));
    H5Sselect_hyperslab(fs.get(), H5S_SELECT_SET, start.data(), nullptr, count.data(), nullptr);
    h5::Handle ms(H5Screate_simple(1, &n, nullptr));
    if (H5Dwrite(d, H5T_NATIVE_FLOAT, ms.get(), fs.get(), H5P_DEFAULT, data) < 0)
      throw IoError(im.path + ": cannot write " + slice_name(t_o, p_o) + " (disk full?)");
  };
  put(im.values.get(), values, false);
  if (m.rgb) {
    if (!rgb) throw IoError(im.path + ": " + slice_name(t_o, p_o) + " written without its rgb channel");
    put(im.rgb.get(), rgb, true);
    im.negative_rgb[m.slice_index(t_o, p_o)] = count_negative_rgb(rgb, m.cells_per_slice());
  }
  im.written[m.slice_index(t_o, p_o)] = true;
}

void TableWriter::commit() {
  Impl& im = *impl_;
  for (std::size_t s = 0; s < im.written.size(); ++s)
    if (!im.written[s])
      throw IoError(im.path + ": " + slice_name(s / im.meta.phi_o.size(), s % im.meta.phi_o.size()) +
                    " was never written");
  if (im.meta.rgb) {
    std::uint64_t negative = 0;
    for (std::uint64_t n : im.negative_rgb) negative += n;
    h5::write_string_attr(im.group.get(), "negative_rgb_cells", std::to_string(negative), im.path);
  }
  im.values.reset();
  im.rgb.reset();
  im.group.reset();
  if (H5Fflush(im.file.get(), H5F_SCOPE_GLOBAL) < 0) throw IoError(im.path + ": flush failed (disk full?)");
  im.file.reset();
  im.out->commit();
}

void write_table(const std::string& path, const TableMeta& meta, const std::vector<float>& values) {
  const std::size_t cells = meta.cells_per_slice();
  if (values.size() != meta.n_slices() * cells)
    throw IoError(path + ": table has " + std::to_string(values.size()) + " values, expected " +
                  std::to_string(meta.n_slices() * cells));
  TableWriter w(path, meta);
  for (std::size_t t = 0; t < meta.theta_o.size(); ++t)
    for (std::size_t p = 0; p < meta.phi_o.size(); ++p)
      w.write_slice(t, p, values.data() + meta.slice_index(t, p) * cells);
  w.commit();
}

}  // namespace bsdfmix
