// A catalog: many tables fitted as one job (`bsdfmix catalog CATALOG.yaml`,
// docs/scale.md). The catalog file lists tables (existing files, fiber presets to
// generate, RGL files or a folder of them to import), each with fit settings; each
// table becomes one ordinary config (the keys of configs/defaults.yaml, checked the
// same way), fitted in turn into one mixture file per table, with a summary CSV.
// Under mpirun every table's batches are shared across the ranks.
#pragma once

#include <string>
#include <vector>

#include "config/config.hpp"
#include "fit/em.hpp"

namespace bsdfmix::scale {

class MpiFarm;

struct CatalogEntry {
  std::string name;  // the file stem of its outputs: <dir>/<name>_mixture.h5 ...
  Config config;     // table, generate or import, fit (outputs set from dir and name)
};

struct Catalog {
  std::string file, device, dir, summary;
  std::vector<CatalogEntry> entries;
};

// Reads and validates a catalog file; throws ConfigError naming the key.
Catalog load_catalog(const std::string& path);
Catalog parse_catalog(const std::string& text, const std::string& name);

// Makes the missing tables and fits every entry in order, then writes the summary CSV
// (rewritten after each table). Under mpirun, rank 0 calls this with its farm, and the
// other ranks serve the entries as jobs, in the same order. The fits' engines run as
// `engine` says.
void run_catalog(const Catalog& catalog, const std::string& device_selector, MpiFarm* farm,
                 const EngineOptions& engine = {});

}  // namespace bsdfmix::scale
