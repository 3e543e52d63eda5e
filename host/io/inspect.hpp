// Human-readable summaries of bsdfmix files, for `bsdfmix inspect`.
#pragma once

#include <string>

namespace bsdfmix {

// What a table or mixture file holds. With `check_cells`, every table slice is read
// and validated (NaN, Inf, negative), and min/max/mean are reported.
std::string describe_file(const std::string& path, bool check_cells);

}  // namespace bsdfmix
