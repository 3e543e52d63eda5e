// The device layer: enumeration, selection, the compile entry point and checked launches,
// with a trivial kernel checked against the CPU.
#include <catch2/catch.hpp>

#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "core/error.hpp"
#include "device/device.hpp"
#include "device/program.hpp"
#include "device/shapes.hpp"
#include "device/selftest.hpp"

using namespace bsdfmix;
namespace fs = std::filesystem;

TEST_CASE("an OpenCL device is found and the self-test kernel matches the CPU", "[device]") {
  const auto infos = enumerate_devices();
  REQUIRE_FALSE(infos.empty());
  for (const auto& i : infos) {
    INFO(i.label());
    CHECK(i.compute_units > 0);
    CHECK(i.max_work_group > 0);
  }
  const auto devices = select_devices("0");
  REQUIRE(devices.size() == 1);
  const auto r = run_selftest(devices[0]);
  INFO("axpy error " << r.axpy_max_abs_error << ", sum error " << r.sum_squares_rel_error);
  CHECK(r.ok());
}

TEST_CASE("devices are selected by index, name, type and environment", "[device]") {
  const auto infos = enumerate_devices();
  CHECK(select_devices("all").size() == infos.size());
  CHECK(select_devices(infos[0].type).front().info().index == 0);
  const std::string part = infos[0].name.substr(0, 4);
  CHECK(select_devices(part).front().info().name == infos[0].name);
  CHECK_THROWS_WITH(select_devices("999"), Catch::Contains("index 999 out of range"));
  CHECK_THROWS_WITH(select_devices("no-such-device-xyz"), Catch::Contains("no device matches 'no-such-device-xyz'"));
  setenv("BSDFMIX_DEVICE", "no-such-device-env", 1);
  CHECK(effective_selector("") == "no-such-device-env");
  CHECK_THROWS_AS(select_devices(""), DeviceError);
  CHECK(effective_selector("0") == "0");
  unsetenv("BSDFMIX_DEVICE");
  CHECK(effective_selector("") == "0");
}

TEST_CASE("a failed build throws with the build log", "[device]") {
  const fs::path dir = fs::temp_directory_path() / "bsdfmix_device_test";
  fs::create_directories(dir);
  std::ofstream(dir / "broken.cl") << "__kernel void broken(__global float* x) { x[0] = undeclared_name; }\n";
  std::ofstream(dir / "common.cl") << kernel_file("common");  // put in front of every program
  setenv("BSDFMIX_KERNEL_DIR", dir.c_str(), 1);
  const auto dev = select_devices("0").front();
  try {
    build_program(dev, "broken");
    FAIL("the broken kernel built");
  } catch (const DeviceError& e) {
    const std::string what = e.what();
    CHECK_THAT(what, Catch::Contains("building kernels/broken.cl"));
    CHECK_THAT(what, Catch::Contains("CL_BUILD_PROGRAM_FAILURE"));
    CHECK_THAT(what, Catch::Contains("undeclared_name"));
    // PoCL's log counts the kernel file's own lines (#line); oclgrind 21.10 ignores #line
    if (dev.info().platform.find("Portable Computing Language") != std::string::npos)
      CHECK_THAT(what, Catch::Contains("broken.cl:1:"));
  }
  // common.cl comes from the same directory as the program
  fs::remove(dir / "common.cl");
  CHECK_THROWS_WITH(build_program(dev, "broken"), Catch::Contains("cannot read kernel source " + (dir / "common.cl").string()));
  CHECK_THROWS_WITH(kernel_source("missing"), Catch::Contains("cannot read kernel source"));
  unsetenv("BSDFMIX_KERNEL_DIR");
  CHECK_THROWS_WITH(kernel_source("missing"), Catch::Contains("no embedded kernel named 'missing'"));
  CHECK_FALSE(kernel_source("selftest").empty());
}

TEST_CASE("programs are cached per device and options", "[device]") {
  const auto dev = select_devices("0").front();
  const cl::Program a = build_program(dev, "selftest", "-DWGS=64");
  const cl::Program b = build_program(dev, "selftest", "-DWGS=64");
  const cl::Program c = build_program(dev, "selftest", "-DWGS=32");
  CHECK(a() == b());
  CHECK(a() != c());
}

TEST_CASE("bad launches are rejected before enqueueing", "[device]") {
  const auto dev = select_devices("0").front();
  const cl::Program p = build_program(dev, "selftest", "-DWGS=64");
  cl::Kernel k(p, "axpy");
  cl::Buffer x(dev.context(), CL_MEM_READ_WRITE, 1024 * sizeof(float));
  k.setArg(0, 1.0f);
  k.setArg(1, x);
  k.setArg(2, x);
  k.setArg(3, 1024u);
  cl::CommandQueue q = dev.make_queue();
  CHECK_THROWS_WITH(launch(q, k, "axpy", cl::NDRange(1000), cl::NDRange(64)),
                    Catch::Contains("global size 1000 in dimension 0 is not a multiple of local size 64"));
  const std::size_t too_big = dev.info().max_work_group * 2;
  CHECK_THROWS_WITH(launch(q, k, "axpy", cl::NDRange(too_big), cl::NDRange(too_big)),
                    Catch::Contains("exceeds the maximum work-group size"));
  CHECK_NOTHROW(launch(q, k, "axpy", cl::NDRange(1024), cl::NDRange(64)));
  q.finish();
}

TEST_CASE("kernel shapes: the table by type, a tuned entry by name and driver, errors with file and line", "[device]") {
  DeviceInfo cpu = select_devices("0").front().info();
  cpu.type = "cpu";
  unsetenv("BSDFMIX_SHAPES");
  CHECK(choose_shape(cpu).shape == make_shape(16, 1));
  CHECK(choose_shape(cpu, true).shape == make_shape(1, 64));
  DeviceInfo small = cpu;
  small.type = "gpu";
  small.max_work_group = 48;  // the work-group is halved until it fits
  CHECK(choose_shape(small).shape == make_shape(1, 32));
  // The one-item-per-work-item kernels: 64 on every row, halved to fit the device.
  CHECK(item_group_size(cpu) == 64);
  CHECK(item_group_size(small) == 32);
  CHECK(item_global_size(1000, 64) == 1024);
  CHECK(item_global_size(1024, 64) == 1024);

  const fs::path file = fs::temp_directory_path() / "bsdfmix_shapes_test.tsv";
  std::ofstream(file) << "# tuned\nother device\t1.0\t1\t128\n" << shape_entry(cpu, make_shape(8, 1), "measured") << "\n";
  setenv("BSDFMIX_SHAPES", file.c_str(), 1);
  const ShapeChoice tuned = choose_shape(cpu);
  CHECK(tuned.shape == make_shape(8, 1));
  CHECK_THAT(tuned.source, Catch::Contains(file.string() + ":3"));
  std::ofstream(file) << cpu.name << "\t" << cpu.driver << "\t3\t1\n";
  CHECK_THROWS_WITH(choose_shape(cpu), Catch::Contains(file.string() + ":1: kernel shape: vec 3"));
  std::ofstream(file) << cpu.name << "\t" << cpu.driver << "\t16\n";
  CHECK_THROWS_WITH(choose_shape(cpu), Catch::Contains(file.string() + ":1: expected"));
  unsetenv("BSDFMIX_SHAPES");
}
