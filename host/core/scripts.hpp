// Running the project's plotting scripts (Python + matplotlib from Debian) from a stage.
#pragma once

#include <string>
#include <vector>

namespace bsdfmix {

// The scripts directory: $BSDFMIX_SCRIPTS, else the source tree's scripts/.
std::string scripts_dir();

// Runs `/usr/bin/python3 <scripts_dir>/<script> args...`; throws Error naming the
// script when it cannot run or exits non-zero. $BSDFMIX_PYTHON overrides the interpreter;
// $BSDFMIX_MODULE_DIR, the folder of the Python module bsdfmix, is this build's unless set.
void run_script(const std::string& script, const std::vector<std::string>& args);

}  // namespace bsdfmix
