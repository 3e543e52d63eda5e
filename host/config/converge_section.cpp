// The `converge` section: the Monte Carlo convergence study.
#include "config/config.hpp"
#include "sampling/estimator_names.hpp"

#include <cmath>
#include <filesystem>

#include "core/domain.hpp"

namespace bsdfmix {

namespace {

void add_scene(const ConfigNode& n, const YAML::Node& s, ConvergeSection& c) {
  if (s.IsScalar()) {
    const std::string file = s.Scalar();
    if (!exists_quiet(file)) n.fail("scene", file + ": no such file");
    try {
      c.scenes.push_back(YAML::LoadFile(file));
    } catch (const YAML::Exception& e) {
      n.fail("scene", "'" + file + "' is not valid YAML (line " + std::to_string(e.mark.line + 1) + "): " + e.msg);
    }
    c.scene_files.push_back(file);
  } else if (s.IsMap()) {
    c.scenes.push_back(s);
    c.scene_files.push_back("");
  } else {
    n.fail("scene", "expected a scene file name, an inline scene mapping, or a list of them");
  }
}

}  // namespace

ConvergeSection parse_converge(const ConfigNode& n) {
  ConvergeSection c;
  if (n.has("scene")) {
    const YAML::Node s = n.raw("scene");
    if (s.IsSequence()) {
      if (s.size() == 0) n.fail("scene", "the list of scenes is empty");
      for (const auto& item : s) add_scene(n, item, c);
    } else {
      add_scene(n, s, c);
    }
  }
  c.theta_o = n.numbers("theta_o");
  c.phi_o = n.numbers("phi_o");
  if (c.theta_o.empty()) n.fail("theta_o", "name at least one outgoing direction");
  if (c.phi_o.empty()) c.phi_o = {0.0};
  for (double t : c.theta_o)
    if (t < -kPi / 2 || t > kPi / 2) n.fail("theta_o", "angle " + std::to_string(t) + " rad is outside [-pi/2, pi/2]");
  for (double p : c.phi_o)
    if (!std::isfinite(p)) n.fail("phi_o", "angles must be finite");
  c.samples_max = n.integer("samples_max", 1, std::int64_t(1) << 32);
  c.runs = static_cast<int>(n.integer("runs", 2, 1000000));
  c.seed = static_cast<std::uint64_t>(n.integer("seed", 0, INT64_MAX));
  c.csv = n.str("csv");
  if (n.has("mixture")) c.mixture = n.str("mixture");
  const bool given = n.has("estimators");
  const YAML::Node est = given ? n.raw("estimators") : YAML::Node();
  if (!given) {
    // The default: the BSDF-only estimators, and under a scene the lighting's too
    c.estimators = {"us_tab", "us_gmm", "is_tab", "is_gmm", "mis_tab", "cdf_tab"};
    if (!c.scenes.empty())
      for (const char* e : {"light", "mis_light_cdf", "mis_light_gmm", "product", "mis_product"}) c.estimators.push_back(e);
  } else if (est.IsScalar()) {
    c.estimators.push_back(est.Scalar());
  } else if (est.IsSequence() && est.size() > 0) {
    for (const auto& e : est) {
      if (!e.IsScalar()) n.fail("estimators", "expected a list of estimator names");
      c.estimators.push_back(e.Scalar());
    }
  } else {
    n.fail("estimators", "expected a list of estimator names (" + estimator_list() + ")");
  }
  for (const auto& e : c.estimators) {
    if (!known_estimator(e)) n.fail("estimators", "unknown estimator '" + e + "' (expected " + estimator_list() + ")");
  }
  c.earned_share = n.has("uniform_fraction") && n.raw("uniform_fraction").IsScalar() &&
                   n.raw("uniform_fraction").Scalar() == "earned";
  if (!c.earned_share) {
    c.uniform_fraction = n.number("uniform_fraction", 0.0, 1.0);
    if (c.uniform_fraction >= 1.0) n.fail("uniform_fraction", "must be below 1 (1 is pure uniform sampling: us_tab), or earned");
  }
  if (n.has("tail_csv")) c.tail_csv = n.str("tail_csv");
  c.light_fraction = n.number("light_fraction", 0.0, 1.0);
  if (c.light_fraction >= 1.0) n.fail("light_fraction", "must be below 1 (1 is light sampling alone: the `light` estimator)");
  c.product_auto = n.has("product_fraction") && n.raw("product_fraction").IsScalar() &&
                   n.raw("product_fraction").Scalar() == "auto";
  if (!c.product_auto) {
    c.product_fraction = n.number("product_fraction", 0.0, 1.0);
    if (c.product_fraction <= 0.0) n.fail("product_fraction", "must be above 0 (0 leaves no product samples), or auto");
    c.product_light = n.number("product_light", 0.0, 1.0);
    if (c.product_fraction + c.product_light > 1.0)
      n.fail("product_light", "product_fraction + product_light must be at most 1 (uniform sampling takes the rest)");
  }
  c.product_components = static_cast<int>(n.integer("product_components", 1, 1024));
  const std::string h = n.str("mis_heuristic");
  if (h != "balance" && h != "power") n.fail("mis_heuristic", "expected balance or power, not '" + h + "'");
  c.power_heuristic = h == "power";
  if (n.has("light_mixture_dir")) c.light_mixture_dir = n.str("light_mixture_dir");
  if (n.has("light_tail_csv")) c.light_tail_csv = n.str("light_tail_csv");
  c.cpu = n.boolean("cpu");
  if (n.has("rgl")) {
    c.rgl = n.str("rgl");
    if (!exists_quiet(c.rgl)) n.fail("rgl", c.rgl + ": no such file");
  }
  return c;
}

}  // namespace bsdfmix
