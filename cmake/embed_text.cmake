# Writes OUT: a C++ file holding the text file IN as bsdfmix::embedded::config_defaults().
file(READ ${IN} hex HEX)
string(REGEX REPLACE "([0-9a-f][0-9a-f])" "0x\\1," bytes "${hex}")
file(WRITE ${OUT}.tmp "// Generated from configs/defaults.yaml at build time. Do not edit.\n#include <string>\nnamespace bsdfmix::embedded {\nstatic const char k_defaults[] = {${bytes}0x00};\nconst std::string& config_defaults() {\n  static const std::string text(k_defaults, sizeof(k_defaults) - 1);\n  return text;\n}\n}  // namespace bsdfmix::embedded\n")
file(RENAME ${OUT}.tmp ${OUT})
