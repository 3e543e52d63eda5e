// Configs: defaults merged under the user's, and every kind of config error.
#include <catch2/catch.hpp>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <cstdio>

#include "config/config.hpp"
#include "render/render_run.hpp"
#include "scene/scene.hpp"
#include "scale/catalog.hpp"
#include "core/error.hpp"
#include "io/table.hpp"

using namespace bsdfmix;
namespace fs = std::filesystem;

namespace {

// A table file that exists, so configs that name it pass the missing-file check.
std::string existing_table() {
  const fs::path dir = fs::temp_directory_path() / "bsdfmix_config_test";
  fs::create_directories(dir);
  const std::string p = (dir / "t.h5").string();
  if (!fs::exists(p)) {
    TableMeta m = make_grid(Domain::Fiber, 2, 1, 2, 4, true);
    write_table(p, m, std::vector<float>(16, 1.0f));
  }
  return p;
}

std::string config_error(const std::string& text) {
  try {
    parse_config(text, "cfg.yaml");
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "(no error)";
}

}  // namespace

TEST_CASE("defaults are merged under the user's keys", "[config]") {
  const Config c = parse_config("table: " + existing_table() + "\nfit:\n  k_max: 8\n", "cfg.yaml");
  REQUIRE(c.fit);
  CHECK(c.fit->k_max == 8);
  CHECK(c.fit->k_min == 1);
  CHECK(c.fit->output == "out/mixture.h5");
  CHECK(c.fit->rgb_copies == 1.2);  // colour copies where a slice's colour error is above 1.2x its luminance's
  CHECK_FALSE(parse_config("table: " + existing_table() + "\nfit:\n  rgb_copies: ~\n", "cfg.yaml").fit->rgb_copies);
  CHECK_FALSE(c.converge);
  CHECK_FALSE(c.generate);
  CHECK(c.device.empty());
}

TEST_CASE("fit settings compare as values", "[config]") {
  const std::string t = "table: " + existing_table() + "\nfit:\n";
  const FitSettings plain = *parse_config(t, "cfg.yaml").fit;
  CHECK(plain == *parse_config(t, "cfg.yaml").fit);
  FitSettings defaults;  // configs/defaults.yaml's fit section is the type's defaults, but for the paths
  defaults.output = "out/mixture.h5";
  defaults.report = "out/fit.csv";
  defaults.search_report = "out/search.csv";
  CHECK(plain == defaults);
  const FitSettings moved = *parse_config(t + "  output: elsewhere/m.h5\n", "cfg.yaml").fit;
  CHECK(moved != plain);
  CHECK(same_result_settings(moved, plain));  // the paths do not make the result
  for (const char* key : {"  k_max: 8\n", "  tolerance: 1e-5\n", "  search: restarts\n", "  rgb_copies: ~\n",
                          "  error_target: 0.05\n", "  refine: none\n"}) {
    INFO(key);
    const FitSettings other = *parse_config(t + key, "cfg.yaml").fit;
    CHECK(other != plain);
    CHECK_FALSE(same_result_settings(other, plain));
  }
  const FitSettings batched = *parse_config(t + "  batch: 7\n", "cfg.yaml").fit;
  CHECK(batched != plain);
  CHECK(same_result_settings(batched, plain));
}

TEST_CASE("a bare section takes every default", "[config]") {
  const Config c = parse_config("table: " + existing_table() + "\nfit:\nconverge:\n", "cfg.yaml");
  REQUIRE(c.fit);
  REQUIRE(c.converge);
  CHECK(c.converge->samples_max == 65536);
  CHECK(c.converge->runs == 64);
  CHECK(c.converge->product_auto);
  CHECK(c.converge->earned_share);  // uniform_fraction: earned
  CHECK(parse_config("table: " + existing_table() + "\nconverge:\n  uniform_fraction: earned\n", "cfg.yaml")
            .converge->earned_share);
  CHECK_FALSE(parse_config("table: " + existing_table() + "\nconverge:\n  uniform_fraction: 0.05\n", "cfg.yaml")
                  .converge->earned_share);  // a number pins it
  CHECK(parse_config("table: " + existing_table() + "\nconverge:\n  uniform_fraction: 0.05\n", "cfg.yaml")
            .converge->uniform_fraction == 0.05);
  CHECK(c.converge->product_light == 0.1);
  CHECK(c.converge->light_fraction == 0.5);
  CHECK_FALSE(c.converge->power_heuristic);
  // the default estimators: the BSDF-only six; under a scene, the lighting's five too
  CHECK(c.converge->estimators ==
        std::vector<std::string>{"us_tab", "us_gmm", "is_tab", "is_gmm", "mis_tab", "cdf_tab"});
  const Config lit = parse_config("table: " + existing_table() + "\nfit:\nconverge:\n  scene:\n    constant: 1\n",
                                  "cfg.yaml");
  REQUIRE(lit.converge);
  CHECK(lit.converge->estimators == std::vector<std::string>{"us_tab", "us_gmm", "is_tab", "is_gmm", "mis_tab",
                                                             "cdf_tab", "light", "mis_light_cdf", "mis_light_gmm",
                                                             "product", "mis_product"});
}

TEST_CASE("converge.rgl: the RGL file of is_rgl and mis_light_rgl, by default import.rgl", "[config]") {
  const std::string t = "table: " + existing_table() + "\n";
  const std::string satin = std::string(BSDFMIX_SOURCE_DIR) + "/data/rgl/satin_rosaline_rgb.bsdf";
  // not named, and no import: empty (no estimator needs it)
  const Config none = parse_config(t + "converge:\n", "cfg.yaml");
  REQUIRE(none.converge);
  CHECK(none.converge->rgl.empty());
  // named
  const Config named = parse_config(t + "converge:\n  estimators: [is_rgl, mis_light_rgl]\n  rgl: " + satin + "\n",
                                    "cfg.yaml");
  REQUIRE(named.converge);
  CHECK(named.converge->rgl == satin);
  CHECK(named.converge->estimators == std::vector<std::string>{"is_rgl", "mis_light_rgl"});
  // not named, but the config imports the table from an RGL file: that one (the stage resolves it)
  const Config imported = parse_config("table: nowhere/satin.h5\nimport:\n  rgl: " + satin +
                                           "\nconverge:\n  estimators: [mis_light_rgl]\n",
                                       "cfg.yaml");
  REQUIRE(imported.converge);
  CHECK(imported.converge->rgl.empty());
  CHECK(imported.import->rgl == satin);
  // neither: one error naming the key
  CHECK_THAT(config_error(t + "converge:\n  estimators: [us_tab, is_rgl]\n"),
             Catch::Contains("cfg.yaml: converge.rgl: is_rgl samples with an RGL file's own warps"));
  CHECK_THAT(config_error(t + "converge:\n  estimators: [mis_light_rgl]\n  rgl: ~\n"),
             Catch::Contains("converge.rgl") && Catch::Contains("mis_light_rgl samples with an RGL file's own warps"));
  CHECK_THAT(config_error(t + "converge:\n  estimators: [is_rgl]\n  rgl: nowhere/x.bsdf\n"),
             Catch::Contains("converge.rgl (line 4): nowhere/x.bsdf: no such file"));
  // never among the default estimators
  const Config lit = parse_config(t + "converge:\n  scene:\n    constant: 1\n", "cfg.yaml");
  for (const auto& e : lit.converge->estimators) CHECK(e.find("rgl") == std::string::npos);
}

TEST_CASE("unknown keys are rejected with their full path", "[config]") {
  const std::string t = "table: " + existing_table() + "\n";
  CHECK_THAT(config_error(t + "fitt:\n  k_max: 3\n"), Catch::Contains("cfg.yaml: fitt (line 2): unknown key"));
  CHECK_THAT(config_error(t + "fit:\n  kmax: 3\n"), Catch::Contains("cfg.yaml: fit.kmax (line 3): unknown key"));
  CHECK_THAT(config_error(t + "converge:\n  samples: 3\n"), Catch::Contains("converge.samples"));
}

TEST_CASE("wrong types and impossible values are named", "[config]") {
  const std::string t = "table: " + existing_table() + "\n";
  CHECK_THAT(config_error(t + "fit:\n  k_max: many\n"),
             Catch::Contains("fit.k_max (line 3): expected an integer, got 'many'"));
  CHECK_THAT(config_error(t + "fit:\n  k_min: 0\n"), Catch::Contains("fit.k_min (line 3): 0 is out of range [1, 128]"));
  CHECK_THAT(config_error(t + "fit:\n  k_min: 5\n  k_max: 3\n"), Catch::Contains("fit.k_max (line 4): 3 is below k_min 5"));
  CHECK_THAT(config_error(t + "converge:\n  samples_max: -4\n"), Catch::Contains("converge.samples_max (line 3): -4 is out of range"));
  CHECK_THAT(config_error(t + "converge:\n  theta_o: [0.1, zero]\n"), Catch::Contains("expected a number or a list of numbers, got 'zero'"));
  CHECK_THAT(config_error(t + "fit: 3\n"), Catch::Contains("cfg.yaml: fit (line 2): expected a mapping"));
  CHECK_THAT(config_error(t + "fit:\n  rgb_copies: -1\n"), Catch::Contains("fit.rgb_copies (line 3): -1 is out of range"));
  CHECK_THAT(config_error(t + "generate:\n  symmetry: maybe\n"), Catch::Contains("generate.symmetry (line 3): expected true or false"));
  // sampling with the lighting
  CHECK_THAT(config_error(t + "converge:\n  estimators: [mis_product, mis_prod]\n"),
             Catch::Contains("converge.estimators (line 3): unknown estimator 'mis_prod'") && Catch::Contains("mis_light_cdf"));
  CHECK_THAT(config_error(t + "converge:\n  mis_heuristic: cutoff\n"),
             Catch::Contains("converge.mis_heuristic (line 3): expected balance or power, not 'cutoff'"));
  CHECK_THAT(config_error(t + "converge:\n  product_fraction: 0.8\n  product_light: 0.3\n"),
             Catch::Contains("converge.product_light (line 4): product_fraction + product_light must be at most 1"));
  CHECK_THAT(config_error(t + "converge:\n  light_fraction: 1\n"), Catch::Contains("converge.light_fraction (line 3): must be below 1"));
  CHECK_THAT(config_error(t + "converge:\n  uniform_fraction: earnt\n"), Catch::Contains("converge.uniform_fraction (line 3)"));
  CHECK_THAT(config_error(t + "converge:\n  uniform_fraction: 1\n"), Catch::Contains("must be below 1 (1 is pure uniform sampling: us_tab), or earned"));
  CHECK_THAT(config_error(t + "converge:\n  product_components: 0\n"), Catch::Contains("converge.product_components (line 3): 0 is out of range"));
}

TEST_CASE("fit rows without radians: a stride, row indices and degrees", "[config]") {
  const std::string t = "table: " + existing_table() + "\n";
  const Config c = parse_config(t + "fit:\n  theta_o_stride: 3\n  theta_o_rows: [0, 2, 4]\n  theta_o_deg: [10, 37.5]\n",
                                "cfg.yaml");
  REQUIRE(c.fit);
  CHECK(c.fit->theta_o_stride == 3);
  CHECK(c.fit->theta_o_rows == std::vector<int>{0, 2, 4});
  CHECK(c.fit->theta_o_deg == std::vector<double>{10, 37.5});
  CHECK(c.fit->theta_o.empty());
  const Config d = parse_config(t + "fit:\n", "cfg.yaml");
  CHECK(d.fit->theta_o_stride == 0);
  CHECK(d.fit->theta_o_rows.empty());
  CHECK(d.fit->theta_o_deg.empty());
  CHECK_THAT(config_error(t + "fit:\n  theta_o_stride: 0\n"), Catch::Contains("fit.theta_o_stride (line 3): 0 is out of range"));
  CHECK_THAT(config_error(t + "fit:\n  theta_o_rows: [1, 2.5]\n"),
             Catch::Contains("fit.theta_o_rows (line 3): 2.5 is not a row index"));
  CHECK_THAT(config_error(t + "fit:\n  theta_o_rows: -1\n"), Catch::Contains("-1 is not a row index"));
  CHECK_THAT(config_error(t + "fit:\n  theta_o_deg: [10, 95]\n"),
             Catch::Contains("fit.theta_o_deg (line 3): angle 95 deg is outside [-90, 90]"));
}

TEST_CASE("missing files and missing keys are named", "[config]") {
  CHECK_THAT(config_error("fit:\n  k_max: 3\n"), Catch::Contains("cfg.yaml: table: missing"));
  CHECK_THAT(config_error("table: nowhere/t.h5\nfit:\n"), Catch::Contains("table (line 1): nowhere/t.h5: no such file"));
  CHECK_THAT(config_error("table: " + existing_table() + "\nconverge:\n  scene: nowhere/scene.yaml\n"),
             Catch::Contains("converge.scene (line 3): nowhere/scene.yaml: no such file"));
  try {
    load_config("nowhere/config.yaml");
    FAIL("no error");
  } catch (const ConfigError& e) {
    CHECK_THAT(e.what(), Catch::Contains("nowhere/config.yaml: no such file"));
  }
  // A generate section makes the missing table acceptable.
  CHECK(config_error("table: nowhere/t.h5\ngenerate:\n  preset: silk\n") == "(no error)");
}

TEST_CASE("invalid YAML is reported with its position", "[config]") {
  CHECK_THAT(config_error("table: [unclosed\n"), Catch::Contains("cfg.yaml: invalid YAML at line"));
  CHECK_THAT(config_error(""), Catch::Contains("the config is empty"));
}

TEST_CASE("the shipped configs parse", "[config]") {
  // Every YAML under configs/, subfolders included: scenes (configs/scenes/) by the scene
  // parser in both domains, catalogs by the catalog loader, configs by the config loader,
  // and the render section of those that have one by the renderer's parser. The failure
  // map's configs (configs/stress/) name tables its script builds: their `table:` is
  // pointed at the shipped table, so that every other key is still checked.
  const fs::path root = BSDFMIX_SOURCE_DIR;
  const fs::path cwd = fs::current_path();
  fs::current_path(root);  // configs name paths relative to the project root
  std::size_t scenes = 0, configs = 0, renders = 0, catalogs = 0;
  for (const auto& e : fs::recursive_directory_iterator(root / "configs")) {
    if (e.path().extension() != ".yaml" || e.path().filename() == "defaults.yaml") continue;
    INFO(e.path());
    const std::string path = e.path().string();
    if (e.path().parent_path().filename() == "scenes") {
      for (const Domain d : {Domain::Hemisphere, Domain::Fiber}) CHECK_NOTHROW(parse_scene(YAML::LoadFile(path), path, "", d));
      ++scenes;
      continue;
    }
    std::ifstream in(path);
    std::stringstream ss;
    ss << in.rdbuf();
    std::string text = ss.str();
    const std::string first_key = [&] {
      std::istringstream lines(text);
      std::string line;
      while (std::getline(lines, line))
        if (!line.empty() && line[0] != '#' && line[0] != ' ') return line.substr(0, line.find(':'));
      return std::string();
    }();
    if (first_key == "catalog") {
      CHECK_NOTHROW(scale::load_catalog(path));
      ++catalogs;
      continue;
    }
    if (e.path().parent_path().filename() == "stress") {
      const std::size_t at = text.find("\ntable: ");
      REQUIRE(at != std::string::npos);
      text.replace(at + 8, text.find('\n', at + 1) - (at + 8), "data/silk_small.h5");
    }
    try {
      const Config c = parse_config(text, path);
      ++configs;
      if (c.render) {
        CHECK_NOTHROW(render::render_settings(c));
        ++renders;
      }
    } catch (const Error& err) {
      FAIL_CHECK(err.what());
    }
  }
  fs::current_path(cwd);
  std::printf("config_test: %zu configs (%zu with a render section), %zu scenes, %zu catalogs parsed\n", configs,
              renders, scenes, catalogs);
  CHECK(scenes >= 4);
  CHECK(renders >= 9);
  CHECK(configs >= 20);
}

TEST_CASE("the quickstart renders the default estimators and writes its summary as quickstart.png", "[config]") {
  const fs::path cwd = fs::current_path();
  fs::current_path(BSDFMIX_SOURCE_DIR);
  std::ifstream in("configs/quickstart.yaml");
  std::stringstream ss;
  ss << in.rdbuf();
  const Config c = parse_config(ss.str(), "configs/quickstart.yaml");
  REQUIRE(c.render);
  const render::RenderSettings s = render::render_settings(c);  // configs name paths relative to the root
  fs::current_path(cwd);
  CHECK(s.summary_figure == "quickstart.png");
  CHECK(s.stand_in);  // the summary's table, stand-in and difference
  CHECK(std::none_of(s.estimators.begin(), s.estimators.end(), render::is_guided));
  CHECK(s.estimators.size() == 6);
}
