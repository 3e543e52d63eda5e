// libFuzzer harness of the RGL tensor-file reader: container checks (RglFile), then the
// BRDF's field checks (RglBrdf) and a few evaluations when a file is accepted. A
// bsdfmix::Error is the expected outcome of a bad file; anything else (a crash, a
// sanitizer report, another exception) is a finding.
#include <array>
#include <cstdint>

#include "core/error.hpp"
#include "fuzz_util.hpp"
#include "tables/rgl_brdf.hpp"
#include "tables/rgl_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = bsdfmix::fuzz::write_temp(".bsdf", data, size);
  try {
    const bsdfmix::RglFile file(path);
    for (const auto& f : file.fields())
      if (f.dtype != 9 && f.count() <= 4096) (void)file.as_double(f);
    const bsdfmix::RglBrdf brdf(path);
    const std::array<double, 3> wo = {0.3, 0.1, 0.948683}, wi = {-0.5, 0.2, 0.842615}, up = {0, 0, 1};
    (void)brdf.eval(wo, wi);
    (void)brdf.eval(up, up);
    (void)brdf.eval(wi, wo);
  } catch (const bsdfmix::Error&) {
  }
  return 0;
}
