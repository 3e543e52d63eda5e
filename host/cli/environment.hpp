// The environment variables that tune how a command runs, read once, at the command
// line's edge, into the values the library takes (docs/formats.md lists them).
#pragma once

#include "fit/em.hpp"
#include "scale/mpi_farm.hpp"

namespace bsdfmix::cli {

struct RunEnvironment {
  EngineOptions engine;     // BSDFMIX_PRECISION (auto, fp32, fp64), BSDFMIX_POOL_LOG (set: log every batch run)
  // the launcher's OMPI_COMM_WORLD_SIZE, PMIX_RANK or PMI_SIZE, BSDFMIX_MPI_ROOT_FITS (0: rank 0
  // only hands out), BSDFMIX_MPI_STATS (a CSV path)
  scale::FarmOptions farm;
};

// Reads them; throws ConfigError naming a variable whose value is not one it takes.
RunEnvironment run_environment();

}  // namespace bsdfmix::cli
