// Numbers as text.
#include "core/format.hpp"

#include <cmath>
#include <cstdio>

namespace bsdfmix {

std::string format_number(double v, const char* printf_format) {
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  if (std::isnan(v)) return "nan";
  char buf[64];
  std::snprintf(buf, sizeof buf, printf_format, v);
  return buf;
}

}  // namespace bsdfmix
