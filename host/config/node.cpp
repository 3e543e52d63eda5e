// A YAML mapping seen as one config section, with typed reads and errors in context.
#include "config/node.hpp"

#include <cmath>

#include "core/error.hpp"
#include "core/format.hpp"
#include "core/suggest.hpp"

namespace bsdfmix {

namespace {
std::string show(const YAML::Node& n) {
  if (n.IsScalar()) return "'" + n.Scalar() + "'";
  if (n.IsSequence()) return "a list";
  if (n.IsMap()) return "a mapping";
  return "nothing";
}
// As an ostream writes a double ("%g"; only out-of-range values reach it, never NaN).
std::string num(double v) { return format_number(v, "%g"); }
}  // namespace

ConfigNode::ConfigNode(std::string file, std::string path, YAML::Node node)
    : file_(std::move(file)), path_(std::move(path)), node_(std::move(node)) {
  if (node_ && !node_.IsNull() && !node_.IsMap())
    throw ConfigError(file_ + ": " + (path_.empty() ? "the document" : path_) +
                      " must be a mapping of keys to values");
}

std::string ConfigNode::where(const std::string& key) const {
  std::string w = file_ + ": " + (path_.empty() ? key : path_ + "." + key);
  if (node_ && node_.IsMap()) {
    const YAML::Node n = node_[key];
    if (n && n.Mark().line >= 0) w += " (line " + std::to_string(n.Mark().line + 1) + ")";
  }
  return w;
}

void ConfigNode::fail(const std::string& key, const std::string& problem) const {
  throw ConfigError(where(key) + ": " + problem);
}

bool ConfigNode::has(const std::string& key) const {
  return node_ && node_.IsMap() && node_[key] && !node_[key].IsNull();
}

YAML::Node ConfigNode::raw(const std::string& key) const {
  if (!has(key)) fail(key, "missing");
  return node_[key];
}

std::string ConfigNode::str(const std::string& key) const {
  const YAML::Node n = raw(key);
  if (!n.IsScalar()) fail(key, "expected a string, got " + show(n));
  return n.Scalar();
}

std::int64_t ConfigNode::integer(const std::string& key, std::int64_t min, std::int64_t max) const {
  const YAML::Node n = raw(key);
  std::int64_t v = 0;
  if (!n.IsScalar() || !YAML::convert<std::int64_t>::decode(n, v))
    fail(key, "expected an integer, got " + show(n));
  if (v < min || v > max)
    fail(key, std::to_string(v) + " is out of range [" + std::to_string(min) + ", " + std::to_string(max) + "]");
  return v;
}

double ConfigNode::number(const std::string& key, double min, double max) const {
  const YAML::Node n = raw(key);
  double v = 0;
  if (!n.IsScalar() || !YAML::convert<double>::decode(n, v) || !std::isfinite(v))
    fail(key, "expected a number, got " + show(n));
  if (v < min || v > max) fail(key, num(v) + " is out of range [" + num(min) + ", " + num(max) + "]");
  return v;
}

bool ConfigNode::boolean(const std::string& key) const {
  const YAML::Node n = raw(key);
  bool v = false;
  if (!n.IsScalar() || !YAML::convert<bool>::decode(n, v)) fail(key, "expected true or false, got " + show(n));
  return v;
}

std::vector<double> ConfigNode::numbers(const std::string& key) const {
  const YAML::Node n = raw(key);
  std::vector<double> out;
  auto one = [&](const YAML::Node& x) {
    double v = 0;
    if (!x.IsScalar() || !YAML::convert<double>::decode(x, v) || !std::isfinite(v))
      fail(key, "expected a number or a list of numbers, got " + show(x));
    out.push_back(v);
  };
  if (n.IsSequence()) {
    for (const auto& x : n) one(x);
    if (out.empty()) fail(key, "the list is empty");
  } else {
    one(n);
  }
  return out;
}

std::vector<double> ConfigNode::numbers(const std::string& key, std::size_t count, const std::string& shape) const {
  std::vector<double> v = numbers(key);
  if (v.size() != count) fail(key, "expected " + shape);
  return v;
}

ConfigNode ConfigNode::child(const std::string& key) const {
  const YAML::Node n = raw(key);
  if (!n.IsMap()) fail(key, "expected a mapping, got " + show(n));
  return ConfigNode(file_, path_.empty() ? key : path_ + "." + key, n);
}

void ConfigNode::reject_unknown(const std::set<std::string>& known) const {
  if (!node_ || !node_.IsMap()) return;
  for (const auto& kv : node_) {
    const std::string k = kv.first.Scalar();
    if (!known.count(k)) {
      std::string list;
      for (const auto& s : known) list += (list.empty() ? "" : ", ") + s;
      const std::string guess = closest_name(k, std::vector<std::string>(known.begin(), known.end()));
      std::string w = file_ + ": " + (path_.empty() ? k : path_ + "." + k);
      if (kv.first.Mark().line >= 0) w += " (line " + std::to_string(kv.first.Mark().line + 1) + ")";
      const std::string hint = guess.empty() ? "" : "; did you mean '" + guess + "'?";
      throw ConfigError(w + ": unknown key" + hint + " (known here: " + list + ")");
    }
  }
}

}  // namespace bsdfmix
