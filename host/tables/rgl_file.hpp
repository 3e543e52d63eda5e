// Reader of the "tensor file" container of the RGL material database (Dupuy & Jakob 2018),
// the `.bsdf` files read by Mitsuba's `measured` plugin and pbrt-v4's MeasuredBxDF.
//
// Layout (little endian):
//   12 bytes  magic "tensor_file\0"
//    2 bytes  version: major, minor (only 1.0 exists)
//    4 bytes  uint32 number of fields
//   per field: uint16 name length, name bytes, uint16 ndim, uint8 dtype,
//              uint64 byte offset of the data from the start of the file,
//              ndim x uint64 shape (row-major, last axis contiguous)
//   field data at the offsets.
// dtype codes: 1 uint8, 2 int8, 3 uint16, 4 int16, 5 uint32, 6 int32, 7 uint64,
// 8 int64, 9 float16, 10 float32, 11 float64.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace bsdfmix {

enum class RglDtype : std::uint8_t {
  UInt8 = 1, Int8, UInt16, Int16, UInt32, Int32, UInt64, Int64, Float16, Float32, Float64
};

// Size in bytes of one element; 0 for an unknown code.
std::size_t rgl_dtype_size(std::uint8_t code);
std::string rgl_dtype_name(std::uint8_t code);

struct RglField {
  std::string name;
  std::uint8_t dtype = 0;
  std::vector<std::uint64_t> shape;
  std::uint64_t offset = 0;  // byte offset of the data in the file
  std::uint64_t count() const;        // number of elements
  std::uint64_t bytes() const;        // count() * element size
  std::string shape_text() const;     // "[1, 8, 128, 128]"
};

class RglFile {
 public:
  // Reads and checks the container: magic, version, every field header and that
  // every field's data lies inside the file. Throws InputError ("<path>: <problem>")
  // or IoError when the file cannot be read.
  explicit RglFile(const std::string& path);

  const std::string& path() const { return path_; }
  const std::vector<std::uint8_t>& bytes() const { return bytes_; }
  const std::vector<RglField>& fields() const { return fields_; }
  int version_major() const { return version_[0]; }
  int version_minor() const { return version_[1]; }

  // nullptr when absent.
  const RglField* find(const std::string& name) const;
  // Throws InputError "<path>: missing field '<name>'".
  const RglField& field(const std::string& name) const;

  // The field's elements converted to double (any numeric dtype but float16).
  std::vector<double> as_double(const RglField& f) const;
  // The raw bytes of a uint8 field as text (the `description`).
  std::string as_text(const RglField& f) const;

 private:
  std::string path_;
  std::vector<std::uint8_t> bytes_;
  std::vector<RglField> fields_;
  std::uint8_t version_[2] = {0, 0};
};

// SHA-256 of a byte buffer, lower-case hex.
std::string sha256_hex(const std::vector<std::uint8_t>& data);

}  // namespace bsdfmix
