// The cells of a CSV file written by the program (no quoting): one vector per line, the
// header line included; a line ending in ',' has an empty last cell. Shared by the tests
// that read fit reports and search CSVs.
#pragma once

#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace bsdfmix::test {

inline std::vector<std::vector<std::string>> csv_rows(const std::string& path) {
  std::ifstream in(path);
  std::vector<std::vector<std::string>> rows;
  for (std::string line; std::getline(in, line);) {
    std::vector<std::string> cells;
    std::stringstream ss(line);
    for (std::string c; std::getline(ss, c, ',');) cells.push_back(c);
    if (!line.empty() && line.back() == ',') cells.emplace_back();
    rows.push_back(cells);
  }
  return rows;
}

}  // namespace bsdfmix::test
