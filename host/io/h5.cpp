// A thin RAII layer over the HDF5 C API.
#include "io/h5.hpp"

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <vector>


#include "core/error.hpp"
#include "core/file_errors.hpp"

namespace bsdfmix::h5 {

void Handle::reset() {
  if (id_ < 0) return;
  switch (H5Iget_type(id_)) {
    case H5I_FILE: H5Fclose(id_); break;
    case H5I_GROUP: H5Gclose(id_); break;
    case H5I_DATASET: H5Dclose(id_); break;
    case H5I_DATASPACE: H5Sclose(id_); break;
    case H5I_DATATYPE: H5Tclose(id_); break;
    case H5I_ATTR: H5Aclose(id_); break;
    case H5I_GENPROP_LST: H5Pclose(id_); break;
    default: break;
  }
  id_ = -1;
}

void quiet_errors() { H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr); }

namespace {

// The number of attributes of an object (0 when it cannot be read).
hsize_t attr_count(hid_t obj) {
  H5O_info_t info;
#if H5_VERSION_GE(1, 12, 0)
  if (H5Oget_info3(obj, &info, H5O_INFO_NUM_ATTRS) < 0) return 0;
#else
  if (H5Oget_info2(obj, &info, H5O_INFO_NUM_ATTRS) < 0) return 0;
#endif
  return info.num_attrs;
}

// Reads every attribute of the object `name` below `root` (in the probe child).
herr_t probe_object(hid_t root, const char* name, const H5O_info_t*, void*) {
  const hid_t obj = H5Oopen(root, name, H5P_DEFAULT);
  if (obj < 0) return 0;
  const hsize_t count = attr_count(obj);
  for (hsize_t i = 0; i < count; ++i) {
    const hid_t a = H5Aopen_by_idx(obj, ".", H5_INDEX_NAME, H5_ITER_INC, i, H5P_DEFAULT, H5P_DEFAULT);
    if (a < 0) continue;
    const hid_t type = H5Aget_type(a);
    const hid_t space = H5Aget_space(a);
    const hssize_t n = H5Sget_simple_extent_npoints(space);
    if (H5Tget_class(type) == H5T_STRING && H5Tis_variable_str(type) > 0 && n == 1) {
      const hid_t mem = H5Tcopy(H5T_C_S1);
      H5Tset_size(mem, H5T_VARIABLE);
      H5Tset_cset(mem, H5Tget_cset(type));
      char* text = nullptr;
      if (H5Aread(a, mem, &text) >= 0 && text) H5free_memory(text);
      H5Tclose(mem);
    } else if (n > 0 && n < (1 << 20)) {
      std::vector<unsigned char> buf(static_cast<std::size_t>(n) * H5Tget_size(type) + 16);
      H5Aread(a, type, buf.data());
    }
    H5Sclose(space);
    H5Tclose(type);
    H5Aclose(a);
  }
  H5Oclose(obj);
  return 0;
}

// Some corrupt metadata (a damaged global heap behind a string attribute) crashes or
// hangs the HDF5 library itself. Every object's attributes are first read in a child
// process: a crash or a hang there is reported as a corrupt file, never met here.
// `name` and `fapl` as H5Fopen takes them; `path` names the file in errors.
void probe_metadata(const std::string& path, const std::string& name, hid_t fapl) {
  std::fflush(nullptr);
  const pid_t pid = ::fork();
  if (pid < 0) return;  // cannot probe: open directly
  if (pid == 0) {
    const hid_t f = H5Fopen(name.c_str(), H5F_ACC_RDONLY, fapl);
    if (f >= 0) {
#if H5_VERSION_GE(1, 12, 0)
      H5Ovisit3(f, H5_INDEX_NAME, H5_ITER_INC, probe_object, nullptr, H5O_INFO_BASIC);
#else
      H5Ovisit2(f, H5_INDEX_NAME, H5_ITER_INC, probe_object, nullptr, H5O_INFO_BASIC);
#endif
    }
    ::_exit(0);
  }
  int status = 0;
  for (int waited_ms = 0;; waited_ms += 10) {
    const pid_t r = ::waitpid(pid, &status, WNOHANG);
    if (r == pid) break;
    if (r < 0) return;
    if (waited_ms >= 30000) {
      ::kill(pid, SIGKILL);
      ::waitpid(pid, &status, 0);
      throw InputError(path + ": corrupt HDF5 metadata (the HDF5 library does not finish reading it)");
    }
    ::usleep(10000);
  }
  if (WIFSIGNALED(status))
    throw InputError(path + ": corrupt HDF5 metadata (the HDF5 library crashes reading it)");
}

}  // namespace

Handle open_file(const std::string& path) {
  quiet_errors();
  require_readable(path);
  if (H5Fis_hdf5(path.c_str()) <= 0) {
    if (const std::string hint = rgl_file_hint(path, file_head(path, 12)); !hint.empty()) throw InputError(hint);
    throw InputError(path + ": not an HDF5 file (corrupt or wrong format)");
  }
  probe_metadata(path, path, H5P_DEFAULT);
  Handle f(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT));
  if (!f.valid()) throw InputError(path + ": cannot open as HDF5 (corrupt or truncated file)");
  return f;
}

Handle open_image(const std::string& path, const std::string& bytes) {
  quiet_errors();
  // HDF5's signature, at offset 0 or past a user block (512, 1024, 2048, ... bytes)
  static const char kSignature[] = "\211HDF\r\n\032\n";
  bool hdf5 = false;
  for (std::size_t at = 0; !hdf5 && at + 8 <= bytes.size(); at = at ? 2 * at : 512)
    hdf5 = bytes.compare(at, 8, kSignature, 8) == 0;
  if (!hdf5) {
    if (const std::string hint = rgl_file_hint(path, bytes.substr(0, 12)); !hint.empty()) throw InputError(hint);
    throw InputError(path + ": not an HDF5 file (corrupt or wrong format)");
  }
  // The core driver over a copy of the bytes, no backing file. It opens only a name that
  // names no file: one below the file itself, which no file system holds.
  Handle fapl(H5Pcreate(H5P_FILE_ACCESS));
  if (!fapl.valid() || H5Pset_fapl_core(fapl.get(), 1 << 20, 0) < 0 ||
      H5Pset_file_image(fapl.get(), const_cast<char*>(bytes.data()), bytes.size()) < 0)
    throw InputError(path + ": cannot open its bytes in memory as HDF5");
  const std::string name = path + "/in-memory";
  probe_metadata(path, name, fapl.get());
  Handle f(H5Fopen(name.c_str(), H5F_ACC_RDONLY, fapl.get()));
  if (!f.valid()) throw InputError(path + ": cannot open as HDF5 (corrupt or truncated file)");
  return f;
}

Handle create_file(const std::string& path) {
  quiet_errors();
  Handle f(H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT));
  if (!f.valid()) throw IoError(path + ": cannot create HDF5 file");
  return f;
}

bool exists(hid_t loc, const std::string& name) {
  return H5Lexists(loc, name.c_str(), H5P_DEFAULT) > 0;
}

Handle open_group(hid_t loc, const std::string& name, const std::string& where) {
  if (!exists(loc, name)) throw InputError(where + ": missing group /" + name);
  Handle g(H5Gopen2(loc, name.c_str(), H5P_DEFAULT));
  if (!g.valid()) throw InputError(where + ": cannot open group /" + name);
  return g;
}

Handle create_group(hid_t loc, const std::string& name, const std::string& where) {
  Handle g(H5Gcreate2(loc, name.c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT));
  if (!g.valid()) throw IoError(where + ": cannot create group " + name);
  return g;
}

Handle open_dataset(hid_t loc, const std::string& name, const std::string& where) {
  if (!exists(loc, name)) throw InputError(where + ": missing dataset " + name);
  Handle d(H5Dopen2(loc, name.c_str(), H5P_DEFAULT));
  if (!d.valid()) throw InputError(where + ": cannot open dataset " + name);
  return d;
}

std::vector<hsize_t> shape(hid_t dataset) {
  Handle space(H5Dget_space(dataset));
  const int rank = H5Sget_simple_extent_ndims(space.get());
  std::vector<hsize_t> dims(rank > 0 ? rank : 0);
  if (rank > 0) H5Sget_simple_extent_dims(space.get(), dims.data(), nullptr);
  return dims;
}

namespace {

template <class T>
std::vector<T> read_all(hid_t loc, const std::string& name, const std::string& where, hid_t mem_type,
                        H5T_class_t want, const char* want_name) {
  Handle d = open_dataset(loc, name, where);
  Handle type(H5Dget_type(d.get()));
  const H5T_class_t cls = H5Tget_class(type.get());
  if (cls != want)
    throw InputError(where + ": dataset " + name + " has the wrong type (expected " + want_name + ")");
  // A dataset's extent costs nothing in the file (unwritten storage reads as the fill
  // value), so a few corrupt bytes can claim 2^40 elements: refuse what no table axis or
  // mixture dataset needs before allocating it.
  constexpr hsize_t kMaxElements = hsize_t(1) << 26;
  hsize_t n = 1;
  for (hsize_t s : shape(d.get())) {
    if (s != 0 && n > kMaxElements / s)
      throw InputError(where + ": dataset " + name + " is impossibly large (more than " +
                       std::to_string(kMaxElements) + " elements; corrupt file?)");
    n *= s;
  }
  if (n > kMaxElements)
    throw InputError(where + ": dataset " + name + " is impossibly large (" + std::to_string(n) +
                     " elements, more than " + std::to_string(kMaxElements) + "; corrupt file?)");
  std::vector<T> out(n);
  if (n > 0 && H5Dread(d.get(), mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, out.data()) < 0)
    throw InputError(where + ": cannot read dataset " + name + " (corrupt or truncated file)");
  return out;
}

void write_all(hid_t loc, const std::string& name, const std::vector<hsize_t>& dims, hid_t file_type,
               hid_t mem_type, const void* data, const std::string& where) {
  Handle space(H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr));
  Handle d(H5Dcreate2(loc, name.c_str(), file_type, space.get(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT));
  if (!d.valid()) throw IoError(where + ": cannot create dataset " + name);
  hsize_t n = 1;
  for (hsize_t s : dims) n *= s;
  if (n > 0 && H5Dwrite(d.get(), mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) < 0)
    throw IoError(where + ": cannot write dataset " + name);
}

}  // namespace

std::vector<double> read_doubles(hid_t loc, const std::string& name, const std::string& where) {
  return read_all<double>(loc, name, where, H5T_NATIVE_DOUBLE, H5T_FLOAT, "floating point");
}
std::vector<float> read_floats(hid_t loc, const std::string& name, const std::string& where) {
  return read_all<float>(loc, name, where, H5T_NATIVE_FLOAT, H5T_FLOAT, "floating point");
}
std::vector<std::int32_t> read_ints(hid_t loc, const std::string& name, const std::string& where) {
  return read_all<std::int32_t>(loc, name, where, H5T_NATIVE_INT32, H5T_INTEGER, "integer");
}

void write_doubles(hid_t loc, const std::string& name, const std::vector<hsize_t>& dims,
                   const double* data, const std::string& where) {
  write_all(loc, name, dims, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, data, where);
}
void write_floats(hid_t loc, const std::string& name, const std::vector<hsize_t>& dims,
                  const float* data, const std::string& where) {
  write_all(loc, name, dims, H5T_IEEE_F32LE, H5T_NATIVE_FLOAT, data, where);
}
void write_ints(hid_t loc, const std::string& name, const std::vector<hsize_t>& dims,
                const std::int32_t* data, const std::string& where) {
  write_all(loc, name, dims, H5T_STD_I32LE, H5T_NATIVE_INT32, data, where);
}

bool has_attr(hid_t obj, const std::string& name) { return H5Aexists(obj, name.c_str()) > 0; }

namespace {
// H5Aread writes every element of an attribute: one that holds an array instead of a
// single value would overflow the one-value buffers below.
void require_single(hid_t attr, const std::string& name, const std::string& where) {
  Handle space(H5Aget_space(attr));
  const hssize_t n = space.valid() ? H5Sget_simple_extent_npoints(space.get()) : -1;
  if (n != 1)
    throw InputError(where + ": attribute '" + name + "' must hold a single value (holds " +
                     (n < 0 ? std::string("an unreadable extent") : std::to_string(n) + " values") + ")");
}
}  // namespace

std::string read_string_attr(hid_t obj, const std::string& name, const std::string& where) {
  if (!has_attr(obj, name)) throw InputError(where + ": missing attribute '" + name + "'");
  Handle a(H5Aopen(obj, name.c_str(), H5P_DEFAULT));
  if (!a.valid()) throw InputError(where + ": cannot open attribute '" + name + "'");
  require_single(a.get(), name, where);
  Handle type(H5Aget_type(a.get()));
  if (H5Tget_class(type.get()) != H5T_STRING)
    throw InputError(where + ": attribute '" + name + "' is not a string");
  if (H5Tis_variable_str(type.get()) > 0) {
    Handle mem(H5Tcopy(H5T_C_S1));
    H5Tset_size(mem.get(), H5T_VARIABLE);
    H5Tset_cset(mem.get(), H5Tget_cset(type.get()));
    char* s = nullptr;
    if (H5Aread(a.get(), mem.get(), &s) < 0 || !s)
      throw InputError(where + ": cannot read attribute '" + name + "'");
    std::string out(s);
    H5free_memory(s);
    return out;
  }
  // One byte more than the file's: a fixed-length string that fills its size (NULLPAD, as
  // h5py writes numpy bytes) keeps its last character beside the terminator.
  const std::size_t size = H5Tget_size(type.get());
  std::string out(size + 1, '\0');
  Handle mem(H5Tcopy(H5T_C_S1));
  H5Tset_size(mem.get(), size + 1);
  H5Tset_cset(mem.get(), H5Tget_cset(type.get()));
  if (H5Aread(a.get(), mem.get(), out.data()) < 0)
    throw InputError(where + ": cannot read attribute '" + name + "'");
  while (!out.empty() && out.back() == '\0') out.pop_back();
  return out;
}

void write_string_attr(hid_t obj, const std::string& name, const std::string& value,
                       const std::string& where) {
  Handle type(H5Tcopy(H5T_C_S1));
  H5Tset_size(type.get(), H5T_VARIABLE);
  H5Tset_cset(type.get(), H5T_CSET_UTF8);
  Handle space(H5Screate(H5S_SCALAR));
  Handle a(H5Acreate2(obj, name.c_str(), type.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT));
  const char* p = value.c_str();
  if (!a.valid() || H5Awrite(a.get(), type.get(), &p) < 0)
    throw IoError(where + ": cannot write attribute '" + name + "'");
}

double read_double_attr(hid_t obj, const std::string& name, const std::string& where) {
  if (!has_attr(obj, name)) throw InputError(where + ": missing attribute '" + name + "'");
  Handle a(H5Aopen(obj, name.c_str(), H5P_DEFAULT));
  if (!a.valid()) throw InputError(where + ": cannot open attribute '" + name + "'");
  require_single(a.get(), name, where);
  double v = 0;
  if (H5Aread(a.get(), H5T_NATIVE_DOUBLE, &v) < 0)
    throw InputError(where + ": attribute '" + name + "' is not a number");
  return v;
}

std::vector<std::string> attr_names(hid_t obj) {
  std::vector<std::string> names;
  const hsize_t count = attr_count(obj);
  for (hsize_t i = 0; i < count; ++i) {
    char buf[256];
    if (H5Aget_name_by_idx(obj, ".", H5_INDEX_NAME, H5_ITER_INC, i, buf, sizeof buf, H5P_DEFAULT) >= 0)
      names.emplace_back(buf);
  }
  return names;
}

}  // namespace bsdfmix::h5
