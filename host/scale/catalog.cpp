// The catalog: one config per table, built from the catalog's shared settings and the
// entry's own, fitted in turn; a summary row per table.
#include "scale/catalog.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include "config/node.hpp"
#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "core/file_errors.hpp"
#include "core/progress.hpp"
#include "pipeline/stages.hpp"
#include "scale/mpi_farm.hpp"
#include "sweep/sweep.hpp"

namespace bsdfmix::scale {

namespace fs = std::filesystem;

namespace {

const std::set<std::string> kCatalogKeys = {"dir", "summary", "presets", "rgl_dir", "generate", "import", "fit", "tables"};
const std::set<std::string> kEntryKeys = {"name", "table", "preset", "rgl", "generate", "import", "fit"};

// `base` with the keys of `over` laid on top (both mappings or null).
YAML::Node overlay(const YAML::Node& base, const YAML::Node& over) {
  YAML::Node out = base && base.IsMap() ? YAML::Clone(base) : YAML::Node(YAML::NodeType::Map);
  if (over && over.IsMap())
    for (const auto& kv : over) out[kv.first.Scalar()] = YAML::Clone(kv.second);
  return out;
}

std::string csv_field(std::string s) {
  std::replace(s.begin(), s.end(), ',', ';');
  return s;
}

}  // namespace

Catalog parse_catalog(const std::string& text, const std::string& name) {
  YAML::Node doc;
  try {
    doc = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw ConfigError(name + ": invalid YAML at line " + std::to_string(e.mark.line + 1) + ": " + e.msg);
  }
  if (!doc || !doc.IsMap()) throw ConfigError(name + ": a catalog is a mapping with a `catalog:` section");
  ConfigNode top(name, "", doc);
  top.reject_unknown({"catalog", "device"});
  Catalog cat;
  cat.file = name;
  cat.device = top.has("device") ? top.str("device") : "";
  const ConfigNode c = top.child("catalog");
  c.reject_unknown(kCatalogKeys);
  const YAML::Node cn = doc["catalog"];
  cat.dir = c.has("dir") ? c.str("dir") : "out/catalog";
  cat.summary = c.has("summary") ? c.str("summary") : (fs::path(cat.dir) / "summary.csv").string();
  for (const char* s : {"generate", "import", "fit"})
    if (c.has(s)) c.child(s);  // a mapping (its keys are checked per table)

  // The entries: presets, the RGL folder, then the listed tables.
  std::vector<std::pair<std::string, YAML::Node>> raw;  // (where, entry mapping)
  if (c.has("presets")) {
    const YAML::Node p = cn["presets"];
    if (!p.IsSequence()) c.fail("presets", "expected a list of fiber preset names");
    for (const auto& v : p) {
      YAML::Node e(YAML::NodeType::Map);
      e["preset"] = v.Scalar();
      raw.emplace_back("catalog.presets", e);
    }
  }
  if (c.has("rgl_dir")) {
    const std::string dir = c.str("rgl_dir");
    if (!fs::is_directory(dir)) c.fail("rgl_dir", "'" + dir + "' is not a folder");
    std::vector<std::string> files;
    for (const auto& f : fs::directory_iterator(dir))
      if (f.path().extension() == ".bsdf") files.push_back(f.path().string());
    std::sort(files.begin(), files.end());
    if (files.empty()) c.fail("rgl_dir", "no .bsdf file in '" + dir + "'");
    for (const auto& f : files) {
      YAML::Node e(YAML::NodeType::Map);
      e["rgl"] = f;
      raw.emplace_back("catalog.rgl_dir", e);
    }
  }
  if (c.has("tables")) {
    const YAML::Node t = cn["tables"];
    if (!t.IsSequence()) c.fail("tables", "expected a list of tables");
    for (std::size_t i = 0; i < t.size(); ++i) {
      const std::string where = "catalog.tables[" + std::to_string(i) + "]";
      if (!t[i].IsMap()) c.fail("tables", "entry " + std::to_string(i) + " is not a mapping");
      ConfigNode(name, where, t[i]).reject_unknown(kEntryKeys);
      raw.emplace_back(where, t[i]);
    }
  }
  if (raw.empty()) c.fail("tables", "the catalog lists no table (presets, rgl_dir or tables)");

  std::set<std::string> names;
  for (const auto& [where, e] : raw) {
    const ConfigNode en(name, where, e);
    const int sources = int(en.has("table")) + int(en.has("preset")) + int(en.has("rgl"));
    if (sources != 1) en.fail("table", "name exactly one of table, preset or rgl");
    std::string entry_name = en.has("name") ? en.str("name")
                             : en.has("preset") ? en.str("preset")
                             : en.has("rgl") ? fs::path(en.str("rgl")).stem().string()
                                             : fs::path(en.str("table")).stem().string();
    if (!names.insert(entry_name).second)
      en.fail("name", "'" + entry_name + "' names two tables of the catalog (give one a `name:`)");
    const fs::path stem = fs::path(cat.dir) / entry_name;
    YAML::Node conf(YAML::NodeType::Map);
    if (!cat.device.empty()) conf["device"] = cat.device;
    if (en.has("preset")) {
      conf["table"] = stem.string() + "_table.h5";
      YAML::Node g = overlay(cn["generate"], e["generate"]);
      g["preset"] = en.str("preset");
      conf["generate"] = g;
    } else if (en.has("rgl")) {
      conf["table"] = stem.string() + "_table.h5";
      YAML::Node im = overlay(cn["import"], e["import"]);
      im["rgl"] = en.str("rgl");
      conf["import"] = im;
    } else {
      conf["table"] = en.str("table");
    }
    YAML::Node fit = overlay(cn["fit"], e["fit"]);
    fit["output"] = stem.string() + "_mixture.h5";
    fit["report"] = stem.string() + "_fit.csv";
    fit["search_report"] = stem.string() + "_search.csv";
    conf["fit"] = fit;
    YAML::Emitter out;
    out << conf;
    cat.entries.push_back({entry_name, parse_config(out.c_str(), name + ": " + where + " (" + entry_name + ")")});
  }
  return cat;
}

Catalog load_catalog(const std::string& path) {
  const std::optional<std::string> text = read_text(path);
  if (!text) {
    const std::string why = unreadable_file(path);  // the one wording: "PATH: no such file"
    throw ConfigError(why.empty() ? path + ": cannot read the catalog" : why);
  }
  return parse_catalog(*text, path);
}

void run_catalog(const Catalog& cat, const std::string& device_selector, MpiFarm* farm, const EngineOptions& engine) {
  const auto t0 = std::chrono::steady_clock::now();
  std::string csv = "table,slices,mean_k,l1_median,l1_p90,table_bytes,mixture_bytes,seconds\n";
  prepare_output(cat.summary, 1 << 16);
  for (std::size_t i = 0; i < cat.entries.size(); ++i) {
    const CatalogEntry& e = cat.entries[i];
    log_line("catalog " + cat.file + ": table " + std::to_string(i + 1) + " of " + std::to_string(cat.entries.size()) +
             ": " + e.name);
    const auto t = std::chrono::steady_clock::now();
    stage_table(e.config, device_selector);
    if (farm) farm->set_job(i);
    const SweepSummary s =
        run_sweep(e.config.table, *e.config.fit, device_selector,
                  SweepOptions{SIZE_MAX, farm ? farm->batch_farm() : nullptr, engine});
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
    std::size_t total_k = 0;
    for (auto [k, n] : s.k_histogram) total_k += std::size_t(k) * n;
    char row[512];
    std::snprintf(row, sizeof row, "%s,%zu,%.3f,%.6g,%.6g,%llu,%llu,%.2f\n", csv_field(e.name).c_str(), s.slices,
                  s.slices ? double(total_k) / double(s.slices) : 0.0, s.l1_median, s.l1_p90,
                  static_cast<unsigned long long>(s.table_file_bytes),
                  static_cast<unsigned long long>(s.mixture_file_bytes), seconds);
    csv += row;
    write_text_atomic(cat.summary, csv);
  }
  const double total = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("catalog %s: %zu tables -> %s, %s in %.1f s\n", cat.file.c_str(), cat.entries.size(), cat.dir.c_str(),
              cat.summary.c_str(), total);
  std::fflush(stdout);
}

}  // namespace bsdfmix::scale
