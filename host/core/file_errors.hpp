// The one wording of an input file that cannot be read, and of an RGL file given where a
// table or mixture file (HDF5) belongs: docs/formats.md, "Exit codes and errors".
#pragma once

#include <string>

namespace bsdfmix {

// Why `path` cannot be opened for reading: "PATH: no such file", "PATH: is a directory"
// or "PATH: cannot read it (REASON)"; "" when it can.
std::string unreadable_file(const std::string& path);

// Throws InputError(unreadable_file(path)) when `path` cannot be opened for reading.
void require_readable(const std::string& path);

// When `head` (a file's first bytes) starts an RGL tensor file: "PATH: this is an RGL
// file: import it with `bsdfmix import rgl PATH -o TABLE.h5`"; else "".
std::string rgl_file_hint(const std::string& path, const std::string& head);

// The first `n` bytes of `path` ("" when it cannot be read).
std::string file_head(const std::string& path, std::size_t n);

}  // namespace bsdfmix
