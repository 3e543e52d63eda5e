// `bsdfmix sample M.h5`: importance samples from a mixture file.
#include <cmath>
#include <cstdio>
#include <string>

#include "cli/commands.hpp"
#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "core/progress.hpp"
#include "device/device.hpp"
#include "io/mixture_file.hpp"
#include "sampling/sampling.hpp"

namespace bsdfmix::cli {

void add_sample(CLI::App& app, Common& common) {
  static std::string file, output;
  static double theta_o = 0, phi_o = 0;
  static std::uint64_t n = 1000, seed = 1;
  static bool cpu = false, degrees = false;
  auto* sub = app.add_subcommand(
      "sample",
      "draw samples from a mixture file for one outgoing direction; writes theta,phi,pdf_omega,valid "
      "(angles in radians, phi in [-pi, pi); pdf_omega per steradian, 0 when invalid; valid 1 or 0)");
  sub->add_option("mixture", file, "mixture file (HDF5)")->required()->check(CLI::ExistingFile);
  sub->add_option("--theta-o", theta_o, "outgoing theta (radians; degrees with --degrees)")->required();
  sub->add_option("--phi-o", phi_o, "outgoing phi (radians; degrees with --degrees)");
  sub->add_option("-n", n, "number of samples (default 1000)")->check(CLI::Range(std::uint64_t(1), std::uint64_t(1) << 32));
  sub->add_option("-o,--output", output, "output CSV")->required();
  sub->add_option("--seed", seed, "seed of the counter-based generator (default 1): sample i is the same on every device");
  sub->add_flag("--cpu", cpu, "sample with the CPU header (include/bsdfmix/mixture.hpp) instead of an OpenCL device");
  sub->add_flag("--degrees", degrees, "--theta-o and --phi-o are in degrees");
  add_common_options(*sub, common);
  sub->callback([&common] {
    Progress::set_enabled(!common.quiet);
    const double to = degrees ? theta_o * kPi / 180 : theta_o, po = degrees ? phi_o * kPi / 180 : phi_o;
    const MixtureFile mf = read_mixture_file(file);
    if (!(to >= theta_lo(mf.domain) && to <= theta_hi(mf.domain)))
      throw ConfigError("sample: --theta-o " + std::to_string(to) + " rad is outside the " + domain_name(mf.domain) +
                        " domain");
    if (!std::isfinite(po)) throw ConfigError("sample: --phi-o must be finite");
    const mix::MixtureSet set = to_mixture_set(mf);
    prepare_output(output, n * 48);
    std::vector<mix::Sample> samples;
    std::string where = "CPU";
    if (cpu) {
      samples = sample_cpu(set, to, po, seed, kSampleStream, 0, std::size_t(n));
    } else {
      const auto devices = select_devices(common.device);
      where = devices.front().info().label();
      samples = sample_device(devices.front(), set, to, po, seed, kSampleStream, 0, std::size_t(n));
    }
    std::string text = "theta,phi,pdf_omega,valid\n";
    text.reserve(std::size_t(n) * 40);
    std::size_t valid = 0;
    char buf[128];
    for (const auto& s : samples) {
      std::snprintf(buf, sizeof buf, "%.9g,%.9g,%.9g,%d\n", s.theta, s.phi, s.valid ? s.pdf_omega : 0.0, s.valid ? 1 : 0);
      text += buf;
      valid += s.valid;
    }
    write_text_atomic(output, text);
    log_line("sample: " + std::to_string(n) + " samples (" + std::to_string(valid) + " valid) on " + where + " -> " +
             output);
  });
}

}  // namespace bsdfmix::cli
