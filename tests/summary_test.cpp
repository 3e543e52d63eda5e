// One median and one rounding in every summary (host/core/stats.*): the quantile is
// numpy's linear one (an even count's median is the mean of the two middle values), and
// `fit`, `inspect` and `compare` print it with two decimals, the same figures for the same
// values.
// labels: cli compare
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "compare/compare.hpp"
#include "core/stats.hpp"
#include "io/mixture_file.hpp"
#include "io/table.hpp"
#include "sweep/sweep.hpp"

using namespace bsdfmix;
namespace fs = std::filesystem;

namespace {

fs::path temp_dir() {
  const fs::path d = fs::temp_directory_path() / "bsdfmix_summary_test";
  fs::create_directories(d);
  return d;
}

// stdout of `bsdfmix ARGS` (the command must succeed).
std::string output_of(const std::string& args) {
  const std::string out = (temp_dir() / "out.txt").string();
  REQUIRE(std::system((std::string(BSDFMIX_BINARY) + " " + args + " > " + out + " 2>/dev/null").c_str()) == 0);
  std::ifstream f(out);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

}  // namespace

TEST_CASE("the quantile is numpy's linear one", "[summary]") {
  CHECK(quantile({}, 0.5) == 0);
  CHECK(quantile({7}, 0.9) == 7);
  CHECK(quantile({4, 1, 3, 2}, 0.5) == Approx(2.5));  // the mean of the two middle values
  CHECK(quantile({1, 2, 3}, 0.5) == 2);
  CHECK(quantile({4, 1, 3, 2}, 0.9) == Approx(3.7));  // numpy.percentile([1, 2, 3, 4], 90)
  CHECK(quantile({4, 1, 3, 2}, 1.0) == 4);
  CHECK(quantile({4, 1, 3, 2}, 0.0) == 1);
  std::vector<double> v;
  for (int i = 1; i <= 90; ++i) v.push_back(i);
  CHECK(quantile(v, 0.5) == Approx(45.5));
  CHECK(quantile(v, 0.9) == Approx(81.1));
  CHECK(percent_text(0.045249) == "4.52%");
  CHECK(percent_text(0.04525001) == "4.53%");
}

TEST_CASE("compare's summary takes the one quantile", "[summary]") {
  Comparison c;
  for (double l1 : {0.01, 0.02, 0.03, 0.04}) {
    SliceComparison s;
    s.l1 = l1;
    s.fitted = true;
    c.slices.push_back(s);
  }
  const std::string text = comparison_summary(c);
  CHECK_THAT(text, Catch::Contains("relative L1 median 2.50%, p90 3.70%"));
}

TEST_CASE("fit and inspect print the same median of the file's l1_rel", "[summary]") {
  // a 4-slice table of one lobe moving with theta_o: an even count of slices
  TableMeta meta = make_grid(Domain::Hemisphere, 4, 1, 12, 24, true);
  std::vector<float> values;
  for (double to : meta.theta_o)
    for (double th : meta.theta_i)
      for (double ph : meta.phi_i)
        values.push_back(float(0.2 + 3 * std::exp(-((th - to) * (th - to) + ph * ph) / 0.08)));
  const std::string table = (temp_dir() / "t.h5").string(), mixture = (temp_dir() / "m.h5").string();
  write_table(table, meta, values);
  const std::string config = (temp_dir() / "fit.yaml").string();
  std::ofstream(config) << "table: " << table << "\nfit:\n  output: " << mixture << "\n  report: "
                        << (temp_dir() / "fit.csv").string() << "\n  search_report: "
                        << (temp_dir() / "search.csv").string() << "\n  k_max: 2\n";
  fs::remove(mixture);
  const std::string fit = output_of("fit -q " + config);
  const MixtureFile m = read_mixture_file(mixture);
  REQUIRE(m.l1_rel.size() == 4);
  const std::string median = "median " + percent_text(quantile(m.l1_rel, 0.5)) + ", p90 " +
                             percent_text(quantile(m.l1_rel, 0.9)) + ", max " + percent_text(quantile(m.l1_rel, 1));
  CHECK_THAT(fit, Catch::Contains("relative L1      " + median));
  CHECK_THAT(output_of("inspect -q " + mixture), Catch::Contains("l1_rel     " + median));
  // where the time went: every phase named, the shares summing to 100% up to rounding
  const std::size_t at = fit.find("time by phase    search ");
  REQUIRE(at != std::string::npos);
  std::istringstream line(fit.substr(at, fit.find('\n', at) - at));
  double sum = 0;
  for (std::string word; line >> word;)
    if (word.size() > 1 && word[word.size() - 2] == '%') sum += std::stod(word);  // "38%,"
    else if (word.back() == '%') sum += std::stod(word);                          // "7%" before "of"
  CHECK(sum >= 97);
  CHECK(sum <= 103);
}

TEST_CASE("the fit summary gives the CPU time and the share of the cores it kept busy", "[summary]") {
  SweepSummary s;
  s.seconds = 10;
  s.cpu_seconds = 15;
  s.cores = 2;
  CHECK(s.cpu_utilization() == Approx(0.75));
  CHECK_THAT(s.text(), Catch::Matchers::Contains("cpu time         15.0 s: 75% of 2 cores over the wall time"));
  s.seconds = 0;  // a run that took no measurable time: no division by zero
  CHECK(s.cpu_utilization() == 0.0);
}

TEST_CASE("the fit summary says where the batches' time went", "[summary]") {
  SweepSummary s;
  CHECK_THAT(s.text(), !Catch::Matchers::Contains("time by phase"));  // nothing fitted here: no line
  s.phases.search = 4;
  s.phases.final_em = 2;
  s.phases.beyond = 0.5;
  s.phases.refine = 3;
  s.phases.rest = 0.5;
  CHECK(s.phases.total() == Approx(10));
  CHECK_THAT(s.text(), Catch::Matchers::Contains("time by phase    search 40%, final EM 20%, past a stalled walk 5%, "
                                                 "L1 refinement 30%, the rest 5% of 10.0 s in batches"));
  FitPhases twice = s.phases;
  twice += s.phases;
  CHECK(twice.total() == Approx(20));
  CHECK(twice.refine == Approx(6));
}
