// `bsdfmix recommend` (docs/sampling.md, "Choosing a sampler"): its CSV's format, one
// recommendation per lighting, and that it is the candidate of least variance, on a small
// table fitted here. Known answer: with f the table itself, the table CDF samples f
// cos(theta_i) up to its variation inside a cell, so it beats the mixture and uniform.
#include <catch2/catch.hpp>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "bench/sampler_choice.hpp"

#include "run_cli.hpp"

using namespace bsdfmix;
using Catch::Matchers::Contains;
namespace fs = std::filesystem;

namespace {

std::string temp_path(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / "bsdfmix_recommend_test";
  fs::create_directories(dir);
  return (dir / name).string();
}

std::string rgl_file() { return std::string(BSDFMIX_SOURCE_DIR) + "/data/rgl/paper_white_rgb.bsdf"; }

using Run = test::CliRun;

Run run(const std::string& args) { return test::run_cli(args, fs::temp_directory_path() / "bsdfmix_recommend_test"); }

using Row = std::map<std::string, std::string>;

std::vector<Row> read_csv(const std::string& path) {
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  std::vector<std::string> names;
  std::stringstream h(line);
  for (std::string f; std::getline(h, f, ',');) names.push_back(f);
  CHECK(line == "material,lighting,sampler,share,views,samples,median_relvar,max_relvar,vs_reference,reference,bytes,"
                "recommended");
  std::vector<Row> rows;
  while (std::getline(in, line)) {
    Row r;
    std::stringstream s(line);
    std::size_t i = 0;
    for (std::string f; i < names.size(); ++i) {
      if (!std::getline(s, f, ',')) f.clear();
      r[names[i]] = f;
    }
    rows.push_back(r);
  }
  return rows;
}

// The fixture: paper_white on a small grid, fitted at K <= 3.
void make_fixture() {
  if (fs::exists(temp_path("mix.h5"))) return;
  REQUIRE(run("import rgl " + rgl_file() + " --theta-o 6 --theta-i 16 --phi-i 32 -q -o " + temp_path("table.h5")).code ==
          0);
  const std::string cfg = temp_path("fit.yaml");
  std::ofstream(cfg) << "table: " << temp_path("table.h5") << "\nfit:\n  output: " << temp_path("mix.h5")
                     << "\n  report: " << temp_path("fit.csv") << "\n  search_report: " << temp_path("search.csv")
                     << "\n  k_min: 1\n  k_max: 3\n  restarts: 1\n  final_restarts: 1\n";
  REQUIRE(run("fit -q " + cfg).code == 0);
}

// Per lighting: exactly one recommended row, and it has the least median_relvar.
std::map<std::string, Row> check_recommendations(const std::vector<Row>& rows) {
  std::map<std::string, Row> chosen;
  std::map<std::string, double> least;
  for (const Row& r : rows) {
    const double v = std::stod(r.at("median_relvar"));
    if (!least.count(r.at("lighting")) || v < least[r.at("lighting")]) least[r.at("lighting")] = v;
    if (r.at("recommended") == "1") {
      CHECK(chosen.count(r.at("lighting")) == 0);
      chosen[r.at("lighting")] = r;
    }
  }
  for (const auto& [lighting, v] : least) {
    INFO(lighting);
    REQUIRE(chosen.count(lighting) == 1);
    CHECK(std::stod(chosen[lighting].at("median_relvar")) == v);
  }
  return chosen;
}

}  // namespace

TEST_CASE("least_variance takes the least median of its lighting", "[recommend]") {
  std::vector<bench::SamplerFigure> f(4);
  f[0] = {"constant", "is_tab", "", {}, 2.0, 0, 0, 0, false};
  f[1] = {"constant", "cdf_tab", "", {}, 0.5, 0, 0, 0, false};
  f[2] = {"sky", "light", "", {}, 0.1, 0, 0, 0, false};
  f[3] = {"sky", "mis_light_gmm", "", {}, 0.3, 0, 0, 0, false};
  CHECK(bench::least_variance(f, "constant") == 1);
  CHECK(bench::least_variance(f, "sky") == 2);
  CHECK(bench::least_variance(f, "none") == -1);
}

TEST_CASE("recommend on the table alone: the table CDF, the least variance", "[recommend]") {
  make_fixture();
  const std::string csv = temp_path("recommend.csv");
  const Run r = run("recommend " + temp_path("mix.h5") + " " + temp_path("table.h5") + " --samples 4096 -q -o " + csv);
  REQUIRE(r.code == 0);
  INFO(r.out << r.err);
  const std::vector<Row> rows = read_csv(csv);
  CHECK(rows.size() == 5);  // is_tab, mis_tab 0.1, mis_tab earned, cdf_tab, us_tab under constant light
  const auto chosen = check_recommendations(rows);
  CHECK(chosen.at("constant").at("sampler") == "cdf_tab");
  CHECK(chosen.at("constant").at("vs_reference") == "1");
  CHECK_THAT(r.out, Contains("BSDF only: take cdf_tab (1.00x the table CDF, "));
  CHECK_THAT(r.out, Contains("with lighting: give --scene"));
}

TEST_CASE("recommend with the RGL file and a scene: a choice per lighting, in the CSV and the text", "[recommend]") {
  make_fixture();
  const std::string csv = temp_path("recommend_rgl.csv");
  const std::string scene = std::string(BSDFMIX_SOURCE_DIR) + "/configs/scenes/sky.yaml";
  const Run r = run("recommend " + temp_path("mix.h5") + " " + temp_path("table.h5") + " --rgl " + rgl_file() +
                    " --scene " + scene + " --views 3 --samples 2048 -q -o " + csv);
  REQUIRE(r.code == 0);
  INFO(r.out << r.err);
  const std::vector<Row> rows = read_csv(csv);
  const auto chosen = check_recommendations(rows);
  CHECK(chosen.size() == 2);
  for (const Row& row : rows) {
    CHECK(row.at("views") == "3");
    CHECK(row.at("samples") == "2048");
    CHECK(row.at("reference") == (row.at("lighting") == "constant" ? "is_rgl" : "mis_light_rgl"));
  }
  for (const auto& [lighting, row] : chosen) {
    const std::string head = lighting == "constant" ? "BSDF only: take " : "with lighting (" + lighting + "): take ";
    CHECK_THAT(r.out, Contains(head + row.at("sampler")));
  }
}
