// A committed batch (sweep/checkpoint.hpp, BatchPart) as bytes and back: what a worker
// of the MPI task farm sends to rank 0. Every number travels as its exact bit pattern
// (the ranks of one job share one byte order: x86-64 and aarch64 are little-endian), so a part decoded on
// rank 0 is the part the worker fitted, bit for bit.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "sweep/checkpoint.hpp"

namespace bsdfmix::scale {

std::vector<std::uint8_t> encode_part(const BatchPart& part);
// Throws InputError on truncated or malformed bytes.
BatchPart decode_part(const std::uint8_t* data, std::size_t size);

}  // namespace bsdfmix::scale
