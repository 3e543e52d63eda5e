// libFuzzer harness of the HDF5 table validator: the input is written to a temporary
// file and opened with TableReader (structure, axes, attributes), then the first and
// last slices (and the rgb channel when present) are read and their cells checked.
// A bsdfmix::Error is the expected outcome of a bad file; anything else is a finding.
// HDF5 itself is not instrumented: a crash inside libhdf5 shows as a SEGV there.
#include <cstdint>

#include "core/error.hpp"
#include "fuzz_util.hpp"
#include "io/table.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = bsdfmix::fuzz::write_temp(".h5", data, size);
  try {
    const bsdfmix::TableReader reader(path);
    const auto& m = reader.meta();
    (void)reader.read_slice(0, 0);
    (void)reader.read_slice(m.theta_o.size() - 1, m.phi_o.size() - 1);
    if (m.rgb) (void)reader.read_slice_rgb(0, 0);
  } catch (const bsdfmix::Error&) {
  }
  return 0;
}
