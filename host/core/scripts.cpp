// Running the project's plotting scripts.
#include "core/scripts.hpp"

#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>

#include "core/error.hpp"

namespace bsdfmix {

namespace {
std::string quote(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}
}  // namespace

std::string scripts_dir() {
  if (const char* d = std::getenv("BSDFMIX_SCRIPTS"); d && *d) return d;
  return std::string(BSDFMIX_SOURCE_DIR) + "/scripts";
}

void run_script(const std::string& script, const std::vector<std::string>& args) {
  const std::string path = scripts_dir() + "/" + script;
  if (!std::filesystem::exists(path))
    throw Error("chart script " + path + " not found (set BSDFMIX_SCRIPTS to the scripts directory)");
  const char* py = std::getenv("BSDFMIX_PYTHON");
  std::string cmd = quote(py && *py ? py : "/usr/bin/python3") + " " + quote(path);
  // The scripts that evaluate mixtures import the Python module bsdfmix: this build's.
  const char* module = std::getenv("BSDFMIX_MODULE_DIR");
  if (!(module && *module)) cmd = "BSDFMIX_MODULE_DIR=" + quote(BSDFMIX_MODULE_DIR) + " " + cmd;
  for (const auto& a : args) cmd += " " + quote(a);
  cmd += " >/dev/null";
  const int status = std::system(cmd.c_str());
  if (status == -1 || !WIFEXITED(status) || WEXITSTATUS(status) != 0)
    throw Error("chart script " + script + " failed (exit " +
                std::to_string(WIFEXITED(status) ? WEXITSTATUS(status) : -1) + "): " + cmd);
}

}  // namespace bsdfmix
