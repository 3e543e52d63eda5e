// A thin RAII layer over the HDF5 C API: handles, typed 1-D reads and writes,
// string attributes. Errors become InputError (reading) or IoError (writing)
// naming the file and the object.
#pragma once

#include <hdf5.h>

#include <cstdint>
#include <string>
#include <vector>

namespace bsdfmix::h5 {

// Owns an hid_t and closes it with the right H5*close.
class Handle {
 public:
  Handle() = default;
  explicit Handle(hid_t id) : id_(id) {}
  ~Handle() { reset(); }
  Handle(Handle&& o) noexcept : id_(o.id_) { o.id_ = -1; }
  Handle& operator=(Handle&& o) noexcept {
    if (this != &o) {
      reset();
      id_ = o.id_;
      o.id_ = -1;
    }
    return *this;
  }
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;
  hid_t get() const { return id_; }
  bool valid() const { return id_ >= 0; }
  void reset();

 private:
  hid_t id_ = -1;
};

// Silences HDF5's own error printing; we report errors ourselves. Every file open and
// create calls it (it only sets what it set before).
void quiet_errors();

Handle open_file(const std::string& path);    // read-only; InputError if missing or not HDF5
// The file `path` from its bytes, already in memory: read-only, the same checks as
// open_file, and nothing more read from the disk.
Handle open_image(const std::string& path, const std::string& bytes);
Handle create_file(const std::string& path);  // truncates; IoError on failure
bool exists(hid_t loc, const std::string& name);
Handle open_group(hid_t loc, const std::string& name, const std::string& where);
Handle create_group(hid_t loc, const std::string& name, const std::string& where);
Handle open_dataset(hid_t loc, const std::string& name, const std::string& where);

// Shape of a dataset.
std::vector<hsize_t> shape(hid_t dataset);

// Whole-dataset reads, converted to the requested type; InputError on a type class mismatch.
std::vector<double> read_doubles(hid_t loc, const std::string& name, const std::string& where);
std::vector<float> read_floats(hid_t loc, const std::string& name, const std::string& where);
std::vector<std::int32_t> read_ints(hid_t loc, const std::string& name, const std::string& where);

// Whole-dataset writes with the given shape (product must equal data size).
void write_doubles(hid_t loc, const std::string& name, const std::vector<hsize_t>& dims,
                   const double* data, const std::string& where);
void write_floats(hid_t loc, const std::string& name, const std::vector<hsize_t>& dims,
                  const float* data, const std::string& where);
void write_ints(hid_t loc, const std::string& name, const std::vector<hsize_t>& dims,
                const std::int32_t* data, const std::string& where);

// String attributes (variable or fixed length on read; variable length on write).
bool has_attr(hid_t obj, const std::string& name);
std::string read_string_attr(hid_t obj, const std::string& name, const std::string& where);
void write_string_attr(hid_t obj, const std::string& name, const std::string& value,
                       const std::string& where);
// Numeric scalar attributes.
double read_double_attr(hid_t obj, const std::string& name, const std::string& where);

// Lists the attribute names of an object.
std::vector<std::string> attr_names(hid_t obj);

}  // namespace bsdfmix::h5
