// Numbers as text for CSV files, logs and error messages.
#pragma once

#include <string>

namespace bsdfmix {

// `v` through the printf conversion `printf_format` (one double conversion: "%.9g",
// "%g", ..); infinities as "inf" and "-inf" and NaN as "nan" whatever the format and the
// NaN's sign bit.
std::string format_number(double v, const char* printf_format);

}  // namespace bsdfmix
