// The table stage: generate or import the config's table when it is missing.
#include <filesystem>

#include "core/error.hpp"
#include "core/progress.hpp"
#include "pipeline/stages.hpp"

namespace bsdfmix {

void stage_table(const Config& config, const std::string&) {
  const bool present = std::filesystem::exists(config.table);
  if (config.generate && (!present || config.generate->force))
    throw UnavailableError(config.file + ": generate: the fiber generator is not yet available in this build");
  if (config.import && (!present || config.import->force))
    throw UnavailableError(config.file + ": import: the RGL importer is not yet available in this build");
  if (present) log_line("table " + config.table + ": present");
}

}  // namespace bsdfmix
