// `bsdfmix devices`: the OpenCL platforms and devices, with the indices that select them.
#include <cstdio>
#include <memory>

#include "cli/commands.hpp"
#include "core/error.hpp"
#include "device/device.hpp"
#include "device/shapes.hpp"
#include "device/selftest.hpp"

namespace bsdfmix::cli {

void add_devices(CLI::App& app, Common& common) {
  auto* sub = app.add_subcommand("devices", "list OpenCL platforms and devices with the indices that select them");
  struct Args {  // the options, kept alive by the callback
    bool check = false;
  };
  const auto args = std::make_shared<Args>();
  sub->add_flag("--check", args->check, "also build and run a self-test kernel on the selected device(s)");
  add_common_options(*sub, common);
  sub->callback([args, &common] {
    const auto infos = enumerate_devices();
    int platform = -1;
    for (const auto& i : infos) {
      if (i.platform_index != platform) {
        platform = i.platform_index;
        std::printf("platform %d: %s\n", platform, i.platform.c_str());
      }
      const ShapeChoice shape = choose_shape(i);
      std::printf("  [%d] %s\n      type %s, %u compute units, %.1f GiB global memory (%.1f GiB in one "
                  "allocation), %.0f KiB local, max work-group %zu, fp64 %s\n      %s, driver %s\n"
                  "      fitting kernels: %s (%s)\n",
                  i.index, i.name.c_str(), i.type.c_str(), i.compute_units, double(i.global_mem) / (1 << 30),
                  double(i.max_alloc) / (1 << 30), double(i.local_mem) / 1024, i.max_work_group,
                  i.fp64 ? "yes" : "no (fp32 fits)", i.version.c_str(), i.driver.c_str(), shape.shape.label().c_str(),
                  shape.source.c_str());
    }
    std::printf("select with --device INDEX|NAME|cpu|gpu|all or BSDFMIX_DEVICE; default: %s\n",
                effective_selector(common.device).c_str());
    if (args->check) {
      bool all_ok = true;
      for (const auto& d : select_devices(common.device)) {
        const auto r = run_selftest(d);
        std::printf("self-test [%d] %s: %s (axpy max error %.2g, sum of squares relative error %.2g)\n",
                    d.info().index, d.info().name.c_str(), r.ok() ? "ok" : "FAILED", r.axpy_max_abs_error,
                    r.sum_squares_rel_error);
        all_ok = all_ok && r.ok();
      }
      if (!all_ok) throw DeviceError("self-test failed: the device computes wrong results");
    }
  });
}

}  // namespace bsdfmix::cli
