// The environment variables that tune how a command runs, read into values.
#include "cli/environment.hpp"

#include <cstdlib>
#include <string>

#include "core/error.hpp"

namespace bsdfmix::cli {

namespace {

// The variable's value; "" when unset.
std::string variable(const char* name) {
  const char* v = std::getenv(name);
  return v ? v : "";
}

}  // namespace

RunEnvironment run_environment() {
  RunEnvironment env;
  if (const std::string p = variable("BSDFMIX_PRECISION"); !p.empty()) {
    try {
      env.engine.precision = parse_precision(p);
    } catch (const ConfigError& e) {
      throw ConfigError(std::string("BSDFMIX_PRECISION: ") + e.what());
    }
  }
  env.engine.pool_log = std::getenv("BSDFMIX_POOL_LOG") != nullptr;
  for (const char* v : {"OMPI_COMM_WORLD_SIZE", "PMIX_RANK", "PMI_SIZE"})
    if (!variable(v).empty()) env.farm.launched = true;
  env.farm.root_fits = variable("BSDFMIX_MPI_ROOT_FITS") != "0";
  env.farm.stats_path = variable("BSDFMIX_MPI_STATS");
  return env;
}

}  // namespace bsdfmix::cli
