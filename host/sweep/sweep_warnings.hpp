// The fit's warnings (docs/fitting.md): K at its cap on many slices, and a table whose
// colours hold negative channels. Each is one line of text, empty when there is nothing
// to say; `bsdfmix fit` prints them after its summary (core/progress.hpp, warn_line).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "io/table.hpp"
#include "sweep/slice_plan.hpp"

namespace bsdfmix {

// K at k_max on at least this share of the slices asks for a larger k_max.
constexpr double kKCapShare = 0.1;

// When k_min < k_max and K reached k_max on kKCapShare of the slices or more: the count
// and the median relative L1 of those slices against the others'.
std::string k_cap_warning(const std::vector<std::int32_t>& k, const std::vector<double>& l1_rel, int k_min, int k_max);

// When the planned slices' rgb holds cells with a negative channel: their share and what
// keeping or clipping them means for a renderer. Empty for a table without rgb.
std::string negative_channel_warning(const TableReader& table, const std::vector<SliceRef>& plan);

}  // namespace bsdfmix
