// A YAML mapping seen as one config section: typed reads that name the key's full
// path and line on error, and a check that rejects keys the section does not know.
#pragma once

#include <yaml-cpp/yaml.h>

#include <cstdint>
#include <filesystem>
#include <set>
#include <system_error>
#include <string>
#include <vector>

namespace bsdfmix {

class ConfigNode {
 public:
  // `file`: the config file, `path`: dotted path of this node ("fit"), `node`: a mapping.
  ConfigNode(std::string file, std::string path, YAML::Node node);

  bool has(const std::string& key) const;  // present and not null
  std::string str(const std::string& key) const;
  std::int64_t integer(const std::string& key, std::int64_t min, std::int64_t max) const;
  double number(const std::string& key, double min, double max) const;
  bool boolean(const std::string& key) const;
  std::vector<double> numbers(const std::string& key) const;  // a number or a list of numbers
  // A list of exactly `count` numbers; else fails with "expected <shape>".
  std::vector<double> numbers(const std::string& key, std::size_t count, const std::string& shape) const;
  ConfigNode child(const std::string& key) const;             // a mapping
  YAML::Node raw(const std::string& key) const;

  // "config.yaml: fit.k_max (line 7)"
  std::string where(const std::string& key) const;
  [[noreturn]] void fail(const std::string& key, const std::string& problem) const;
  const std::string& file() const { return file_; }
  const std::string& path() const { return path_; }

  // Throws ConfigError for any key of this mapping that is not in `known`.
  void reject_unknown(const std::set<std::string>& known) const;

 private:
  std::string file_, path_;
  YAML::Node node_;
};

// std::filesystem::exists without the exception: a name the file system refuses (too
// long, a component that is a file) is reported as a missing file, in context.
inline bool exists_quiet(const std::string& path) {
  std::error_code ec;
  return std::filesystem::exists(path, ec);
}

}  // namespace bsdfmix
