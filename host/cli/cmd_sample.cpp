// `bsdfmix sample M.h5`: importance samples from a mixture file.
#include <cmath>
#include <cstdio>
#include <memory>
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
  struct Args {  // the options, kept alive by the callback
    std::string file, output;
    double theta_o = 0, phi_o = 0;
    std::uint64_t n = 1000, seed = 1;
    bool cpu = false, degrees = false;
  };
  const auto args = std::make_shared<Args>();
  auto* sub = app.add_subcommand(
      "sample",
      "draw samples from a mixture file for one outgoing direction; writes theta,phi,pdf_omega,valid "
      "(angles in radians, phi in [-pi, pi); pdf_omega per steradian, 0 when invalid; valid 1 or 0)");
  sub->add_option("mixture", args->file, "mixture file (HDF5)")->required()->check(existing_file());
  sub->add_option("--theta-o", args->theta_o, "outgoing theta (radians; degrees with --degrees)")->required();
  sub->add_option("--phi-o", args->phi_o, "outgoing phi (radians; degrees with --degrees)");
  sub->add_option("-n", args->n, "number of samples")->check(CLI::Range(std::uint64_t(1), std::uint64_t(1) << 32));
  sub->add_option("-o,--output", args->output, "output CSV")->required();
  sub->add_option("--seed", args->seed, "seed of the counter-based generator: sample i is the same on every device");
  sub->add_flag("--cpu", args->cpu, "sample with the CPU header (include/bsdfmix/mixture.hpp) instead of an OpenCL device");
  sub->add_flag("--degrees", args->degrees, "--theta-o and --phi-o are in degrees");
  add_common_options(*sub, common);
  sub->callback([args, &common] {
    Progress::set_enabled(!common.quiet);
    const auto radians = [&](double v) { return args->degrees ? v * kPi / 180 : v; };
    const double to = radians(args->theta_o), po = radians(args->phi_o);
    const MixtureFile mf = read_mixture_file(args->file);
    if (!(to >= theta_lo(mf.domain) && to <= theta_hi(mf.domain)))
      throw ConfigError("sample: --theta-o " + std::to_string(to) + " rad is outside the " + domain_name(mf.domain) +
                        " domain");
    if (!std::isfinite(po)) throw ConfigError("sample: --phi-o must be finite");
    const mix::MixtureSet set = to_mixture_set(mf);
    prepare_output(args->output, args->n * 48);
    std::vector<mix::Sample> samples;
    std::string where = "CPU";
    if (args->cpu) {
      samples = sample_cpu(set, to, po, args->seed, kSampleStream, 0, std::size_t(args->n));
    } else {
      const auto devices = select_devices(common.device);
      where = devices.front().info().label();
      samples = sample_device(devices.front(), set, to, po, args->seed, kSampleStream, 0, std::size_t(args->n));
    }
    std::string text = "theta,phi,pdf_omega,valid\n";
    text.reserve(std::size_t(args->n) * 40);
    std::size_t valid = 0;
    char buf[128];
    for (const auto& s : samples) {
      std::snprintf(buf, sizeof buf, "%.9g,%.9g,%.9g,%d\n", s.theta, s.phi, s.valid ? s.pdf_omega : 0.0, s.valid ? 1 : 0);
      text += buf;
      valid += s.valid;
    }
    write_text_atomic(args->output, text);
    log_line("sample: " + std::to_string(args->n) + " samples (" + std::to_string(valid) + " valid) on " + where + " -> " +
             args->output);
  });
}

}  // namespace bsdfmix::cli
