// The warnings that save a wasted fit (docs/rgl.md, docs/fitting.md): an import grid that
// misses the file's peak, negative channels kept signed, K at its cap on many slices.
// Each appears once, on stderr, as "warning: ...", when it should, and not otherwise.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include <hdf5.h>

#include "core/format.hpp"
#include "core/progress.hpp"
#include "io/h5.hpp"
#include "io/table.hpp"
#include "sweep/slice_plan.hpp"
#include "sweep/sweep_warnings.hpp"
#include "tables/rgl_lobe.hpp"
#include "tables/rgl_warnings.hpp"

#include "run_cli.hpp"

using namespace bsdfmix;
using Catch::Matchers::Contains;
namespace fs = std::filesystem;

namespace {

std::string rgl_path(const std::string& stem) { return std::string(BSDFMIX_SOURCE_DIR) + "/data/rgl/" + stem + ".bsdf"; }

std::string temp_path(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / "bsdfmix_warnings_test";
  fs::create_directories(dir);
  return (dir / name).string();
}

using Run = test::CliRun;

Run run(const std::string& args) { return test::run_cli(args, fs::temp_directory_path() / "bsdfmix_warnings_test"); }

// How many lines of `text` start with "warning: " and contain `what`.
int warnings(const std::string& text, const std::string& what) {
  int n = 0;
  std::size_t at = 0;
  while (at < text.size()) {
    const std::size_t end = std::min(text.find('\n', at), text.size());
    const std::string line = text.substr(at, end - at);
    n += line.rfind("warning: ", 0) == 0 && line.find(what) != std::string::npos;
    at = end + 1;
  }
  return n;
}

Run import(const std::string& stem, const std::string& grid, const std::string& extra = "") {
  return run("import rgl " + rgl_path(stem) + " " + grid + " " + extra + " --quiet -o " + temp_path(stem + ".h5"));
}

}  // namespace

TEST_CASE("import: a grid that misses the file's peak is warned of, with --resolve's cost", "[warnings]") {
  // cc_iris_purple_gem's grazing peak is far sharper than 6 x 10 x 20 cells (docs/rgl.md)
  const Run coarse = import("cc_iris_purple_gem_rgb", "--theta-o 6 --theta-i 10 --phi-i 20");
  REQUIRE(coarse.code == 0);
  INFO(coarse.err);
  CHECK(warnings(coarse.err, "against the file's peak") == 1);
  CHECK(warnings(coarse.err, "import with --resolve (") == 1);
  CHECK(warnings(coarse.err, " cells, ") == 1);
  // paper_white has no sharp lobe: its default grid holds its peak
  const Run fine = import("paper_white_rgb", "");
  REQUIRE(fine.code == 0);
  CHECK(warnings(fine.err, "") == 0);
}

TEST_CASE("the coarse-grid rule: below half the peak warns, above does not", "[warnings]") {
  RglLobe l;
  l.theta_o = 0.5;
  l.theta_i = 0.5;
  l.peak = 100 * std::cos(0.5);  // f 100 at the peak
  l.fwhm_theta = l.fwhm_phi = 0.01;
  const std::vector<RglLobe> lobes{l};
  CHECK(rgl_peak_f(lobes) == Approx(100));
  CHECK(rgl_coarse_grid_warning("x", lobes, 51, 10, 10, 20, false).empty());
  const std::string w = rgl_coarse_grid_warning("x", lobes, 49, 10, 10, 20, false);
  CHECK_THAT(w, Contains("largest f is 49 against the file's peak 100") && Contains("--resolve ("));
  CHECK_THAT(rgl_coarse_grid_warning("x", lobes, 49, 10, 10, 20, true), Contains("at its caps"));
}

TEST_CASE("import: negative channels kept signed are warned of with their share; clipped or absent, not", "[warnings]") {
  const std::string grid = "--theta-o 4 --theta-i 16 --phi-i 32";
  const Run kept = import("cg_sunflower_rgb", grid);
  REQUIRE(kept.code == 0);
  INFO(kept.err);
  CHECK(warnings(kept.err, "% of cells hold a negative R, G or B") == 1);
  CHECK(warnings(kept.err, "--negative clip") == 1);
  const Run clipped = import("cg_sunflower_rgb", grid, "--negative clip");
  REQUIRE(clipped.code == 0);
  CHECK(warnings(clipped.err, "negative") == 0);
  const Run none = import("paper_white_rgb", grid);
  REQUIRE(none.code == 0);
  CHECK(warnings(none.err, "negative") == 0);
  CHECK(rgl_negative_warning("x", 0, 100, false).empty());
  CHECK_THAT(rgl_negative_warning("x", 37, 100, false), Contains("x: 37.0% of cells"));
}

TEST_CASE("fit: the table's negative channels are named in the fit's warnings", "[warnings]") {
  Progress::set_enabled(false);
  const std::string grid = "--theta-o 4 --theta-i 16 --phi-i 32";
  REQUIRE(import("cg_sunflower_rgb", grid).code == 0);
  REQUIRE(import("paper_white_rgb", grid).code == 0);
  const TableReader sunflower(temp_path("cg_sunflower_rgb.h5")), paper(temp_path("paper_white_rgb.h5"));
  const auto plan = plan_slices(sunflower.meta(), {}, {});
  // The count the import wrote, over the table's cells: the slices are not read again.
  const std::int64_t counted = sunflower.meta().negative_rgb_cells;
  std::int64_t scanned = 0;
  for (const SliceRef& r : plan) {
    const std::vector<float> rgb = sunflower.read_slice_rgb(r.t_o, r.p_o);
    for (std::size_t c = 0; c < rgb.size(); c += 3) scanned += rgb[c] < 0 || rgb[c + 1] < 0 || rgb[c + 2] < 0;
  }
  CHECK(counted == scanned);
  CHECK(counted > 0);
  CHECK_THAT(negative_channel_warning(sunflower, plan), Contains("% of the table's cells hold a negative R, G or B"));
  CHECK(paper.meta().negative_rgb_cells == 0);
  CHECK(negative_channel_warning(paper, plan_slices(paper.meta(), {}, {})).empty());
  // A table written without the count: the fitted slices are read and counted.
  const std::string old = temp_path("cg_sunflower_rgb_uncounted.h5");
  std::filesystem::copy_file(temp_path("cg_sunflower_rgb.h5"), old, std::filesystem::copy_options::overwrite_existing);
  {
    h5::Handle f(H5Fopen(old.c_str(), H5F_ACC_RDWR, H5P_DEFAULT));
    h5::Handle g(H5Gopen2(f.get(), "table", H5P_DEFAULT));
    REQUIRE(H5Adelete(g.get(), "negative_rgb_cells") >= 0);
  }
  const TableReader uncounted(old);
  CHECK(uncounted.meta().negative_rgb_cells == -1);
  const std::string w = negative_channel_warning(uncounted, plan);
  CHECK_THAT(w, Contains("% of the fitted cells hold a negative R, G or B"));
  CHECK_THAT(w, Contains(format_number(100.0 * double(scanned) / double(plan.size() * uncounted.meta().cells_per_slice()), "%.1f") + "%"));
}

TEST_CASE("fit: K at k_max on 10% of the slices or more is warned of", "[warnings]") {
  const std::vector<double> l1(10, 0.05);
  std::vector<std::int32_t> k(10, 3);
  CHECK(k_cap_warning(k, l1, 1, 8).empty());
  k[0] = 8;  // 1 of 10: the threshold
  CHECK_THAT(k_cap_warning(k, l1, 1, 8), Contains("K reached k_max 8 on 1 of 10 slices: raise fit.k_max"));
  std::vector<std::int32_t> few(11, 3);
  few[0] = 8;  // 1 of 11: under it
  CHECK(k_cap_warning(few, std::vector<double>(11, 0.05), 1, 8).empty());
  CHECK(k_cap_warning(std::vector<std::int32_t>(10, 4), l1, 4, 4).empty());  // a fixed K is not a cap
  // The medians are the summaries' (core/stats): an even count's is the mean of the middle two.
  std::vector<double> two = l1;
  k[1] = 8;
  two[0] = 0.02;
  two[1] = 0.04;
  CHECK_THAT(k_cap_warning(k, two, 1, 8), Contains("relative L1 median 3.00% on those slices, 5.00% on the others"));
}

TEST_CASE("fit: the CLI prints the K-cap warning once after its summary", "[warnings]") {
  const std::string table = temp_path("cg_sunflower_rgb.h5");
  REQUIRE(import("cg_sunflower_rgb", "--theta-o 4 --theta-i 16 --phi-i 32").code == 0);
  const std::string cfg = temp_path("fit.yaml");
  std::ofstream(cfg) << "table: " << table << "\nfit:\n  output: " << temp_path("mix.h5") << "\n  report: "
                     << temp_path("fit.csv") << "\n  search_report: " << temp_path("search.csv")
                     << "\n  k_min: 1\n  k_max: 2\n  restarts: 1\n  final_restarts: 1\n";
  const Run r = run("fit -q " + cfg);
  REQUIRE(r.code == 0);
  INFO(r.err);
  CHECK(warnings(r.err, "K reached k_max 2 on ") == 1);
  CHECK(warnings(r.err, "hold a negative R, G or B") == 1);
  CHECK_THAT(r.out, Contains("relative L1"));
}
