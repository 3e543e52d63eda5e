// A sweep's memory does not grow with what it has fitted: the checkpoint keeps its parts on
// disk and holds only their slice indices.
// labels: fit sweep
#include <catch2/catch.hpp>

#include <filesystem>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "core/progress.hpp"
#include "sweep/checkpoint.hpp"

namespace fs = std::filesystem;
using namespace bsdfmix;

namespace {

fs::path temp_dir() {
  const fs::path d = fs::temp_directory_path() / "bsdfmix_checkpoint_test";
  fs::create_directories(d);
  return d;
}

// A part of `n` slices from `first` on, one Gaussian each.
BatchPart make_part(std::size_t first, std::size_t n) {
  BatchPart part;
  part.mixture.azimuthal = false;
  for (std::size_t s = first; s < first + n; ++s) {
    part.slice_index.push_back(s);
    part.mixture.add_slice(0.1 * double(s), 0.2, 1.0 + double(s), -1.0, 0.01, {1.0}, {0.3, 0.4}, {0.01, 0.0, 0.02});
    ReportRow row;
    row.slice = s;
    row.k = 1;
    row.status = "ok";
    part.report.push_back(row);
    part.search.push_back(SearchRow{s, 1, 0, -1.0, 0.01, 0.02, true});
  }
  part.slices_hash = "hash" + std::to_string(first);
  return part;
}

}  // namespace

TEST_CASE("a checkpoint holds its parts' slice indices, not their mixtures, and reads them back in order",
          "[fit][crash]") {
  Progress::set_enabled(false);
  const std::string output = (temp_dir() / "mixture.h5").string();
  fs::remove_all(output + ".parts");
  {
    Checkpoint c(output, "fingerprint");
    c.commit(make_part(4, 3));
    c.commit(make_part(0, 4));
    REQUIRE(c.parts().size() == 2);
    CHECK(c.parts().at(4).slice_index == std::vector<std::size_t>{4, 5, 6});
    CHECK(c.parts().at(0).slices_hash == "hash0");
    CHECK(c.done(6));
    CHECK_FALSE(c.done(7));
  }
  Checkpoint resumed(output, "fingerprint");
  REQUIRE(resumed.parts().size() == 2);
  std::vector<std::size_t> order;
  std::vector<double> scales;
  resumed.each_part([&](BatchPart&& p) {
    order.insert(order.end(), p.slice_index.begin(), p.slice_index.end());
    scales.insert(scales.end(), p.mixture.scale.begin(), p.mixture.scale.end());
    CHECK(p.report.size() == p.slice_index.size());
  });
  CHECK(order == std::vector<std::size_t>{0, 1, 2, 3, 4, 5, 6});
  CHECK(scales == std::vector<double>{1, 2, 3, 4, 5, 6, 7});
  // The mixtures live in the part files only: without them there is nothing to read back.
  fs::remove(fs::path(resumed.parts().at(4).path));
  CHECK_THROWS_AS(resumed.each_part([](BatchPart&&) {}), Error);
  resumed.remove();
  CHECK_FALSE(fs::exists(output + ".parts"));
}
