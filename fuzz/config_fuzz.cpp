// libFuzzer harness of the YAML config parser (parse_config: YAML, unknown keys, types,
// ranges, scene files). Run it from the repository root so that the seeds' relative
// paths (tables, scenes) resolve. A bsdfmix::Error is the expected outcome of a bad
// config; anything else (a crash, a sanitizer report, another exception such as a
// YAML::Exception escaping the parser) is a finding.
#include <cstdint>
#include <string>

#include "config/config.hpp"
#include "core/error.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    (void)bsdfmix::parse_config(text, "fuzz.yaml");
  } catch (const bsdfmix::Error&) {
  }
  return 0;
}
