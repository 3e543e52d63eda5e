// The one list of estimators: the built-in ones in their listing order (the study's and
// the renderer's names each keep the order of their lists), then the registered ones.
#include <deque>
#include <map>
#include <mutex>
#include <stdexcept>
#include <vector>

#include "core/error.hpp"
#include "sampling/estimator_builtins.hpp"

namespace bsdfmix {

namespace {

struct Registry {
  std::deque<EstimatorInfo> list;
  std::map<int, std::size_t> by_id;
  int next_id = kBuiltinEstimators;
  void add(EstimatorInfo e) {
    by_id[int(e.id)] = list.size();
    list.push_back(std::move(e));
  }
};

Registry& registry() {
  static Registry r = [] {
    Registry b;
    for (auto make : {builtin::us_tab,        builtin::us_gmm,      builtin::is_tab,        builtin::is_gmm,
                      builtin::uniform,       builtin::mis_tab,     builtin::cdf_tab,       builtin::light,
                      builtin::mis_light_cdf, builtin::mis_light_gmm, builtin::product,     builtin::mis_product,
                      builtin::guided,        builtin::guided_product, builtin::is_rgl,     builtin::mis_light_rgl})
      b.add(make());
    return b;
  }();
  return r;
}

std::mutex& registry_mutex() {
  static std::mutex m;
  return m;
}

// "a, b, .. or z" of the names the predicate keeps
template <class Keep>
std::string name_list(Keep keep) {
  std::vector<const std::string*> names;
  for (const EstimatorInfo& e : estimators())
    if (keep(e)) names.push_back(&e.name);
  std::string s;
  for (std::size_t i = 0; i < names.size(); ++i)
    s += std::string(i ? (i + 1 == names.size() ? " or " : ", ") : "") + *names[i];
  return s;
}

}  // namespace

Estimator register_estimator(EstimatorInfo info) {
  std::lock_guard<std::mutex> lock(registry_mutex());
  Registry& r = registry();
  if (info.name.empty()) throw std::invalid_argument("register_estimator: an estimator needs a name");
  for (const EstimatorInfo& e : r.list)
    if (e.name == info.name) throw std::invalid_argument("register_estimator: '" + info.name + "' is taken");
  if (info.device_id >= 0)
    throw std::invalid_argument("register_estimator: '" + info.name +
                                "': kernels/sample.cl implements only the built-in estimators");
  info.id = Estimator(r.next_id++);
  r.add(info);
  return info.id;
}

const std::deque<EstimatorInfo>& estimators() { return registry().list; }

const EstimatorInfo& estimator_info(Estimator e) {
  const Registry& r = registry();
  const auto it = r.by_id.find(int(e));
  if (it == r.by_id.end()) throw std::out_of_range("estimator id " + std::to_string(int(e)) + " is not registered");
  return r.list[it->second];
}

const EstimatorInfo* find_estimator(const std::string& name) {
  for (const EstimatorInfo& e : estimators())
    if (e.name == name) return &e;
  return nullptr;
}

std::string estimator_list() {
  return name_list([](const EstimatorInfo& e) { return e.in_study(); });
}

std::string path_estimator_list() {
  return name_list([](const EstimatorInfo& e) { return e.render.renders; });
}

const char* estimator_name(Estimator e) {
  const Registry& r = registry();
  const auto it = r.by_id.find(int(e));
  return it == r.by_id.end() ? "?" : r.list[it->second].name.c_str();
}

Estimator parse_estimator(const std::string& name, const std::string& where) {
  const EstimatorInfo* e = find_estimator(name);
  if (e == nullptr || !e->in_study())
    throw ConfigError(where + ": unknown estimator '" + name + "' (expected " + estimator_list() + ")");
  return e->id;
}

}  // namespace bsdfmix
