// The `fit` section: the Gaussian-count search and the final fits.
#include <cmath>

#include "config/config.hpp"
#include "core/domain.hpp"
#include "core/format.hpp"
#include "fit/em.hpp"

namespace bsdfmix {

FitSection parse_fit(const ConfigNode& n) {
  FitSection f;
  f.output = n.str("output");
  f.report = n.str("report");
  f.search_report = n.str("search_report");
  f.k_min = static_cast<int>(n.integer("k_min", 1, kEmMaxK));
  f.k_max = static_cast<int>(n.integer("k_max", 1, kEmMaxK));
  if (f.k_max < f.k_min) n.fail("k_max", std::to_string(f.k_max) + " is below k_min " + std::to_string(f.k_min));
  f.seed = static_cast<std::uint64_t>(n.integer("seed", 0, INT64_MAX));
  f.restarts = static_cast<int>(n.integer("restarts", 1, 1000));
  f.final_restarts = static_cast<int>(n.integer("final_restarts", 1, 1000));
  f.iterations = static_cast<int>(n.integer("iterations", 1, 1000000));
  f.final_iterations = static_cast<int>(n.integer("final_iterations", 1, 1000000));
  f.tolerance = n.number("tolerance", 0.0, 1.0);
  f.batch = static_cast<int>(n.integer("batch", 0, 1000000));
  f.k_penalty = n.number("k_penalty", 0.0, 1.0);
  if (n.has("error_target")) f.error_target = n.number("error_target", 1e-6, 2.0);
  f.search_pool = static_cast<int>(n.integer("search_pool", 1, 16));
  const std::string search = n.str("search");
  const std::optional<SearchStrategy> strategy = search_strategy(search);
  if (!strategy) n.fail("search", "'" + search + "' is not a search method (expected smem or restarts)");
  f.search = *strategy;
  f.refine = n.str("refine");
  if (f.refine != "l1" && f.refine != "none")
    n.fail("refine", "'" + f.refine + "' is not a refinement (expected l1 or none)");
  f.refine_evaluations = static_cast<int>(n.integer("refine_evaluations", 1, 100000));
  f.refine_kl = n.number("refine_kl", 0.0, 1000.0);
  f.refine_rgb = n.number("refine_rgb", 0.0, 0.9);
  f.rgb_copies.reset();
  if (n.has("rgb_copies")) f.rgb_copies = n.number("rgb_copies", 0.0, 100.0);
  f.map = n.str("map");
  if (f.map != "auto" && f.map != "equal_area" && f.map != "theta_phi")
    n.fail("map", "'" + f.map + "' is not a map (expected auto, equal_area or theta_phi)");
  if (n.has("theta_o")) {
    f.theta_o = n.numbers("theta_o");
    for (double t : f.theta_o)
      if (t < -kPi / 2 || t > kPi / 2) n.fail("theta_o", "angle " + std::to_string(t) + " rad is outside [-pi/2, pi/2]");
  }
  if (n.has("phi_o")) f.phi_o = n.numbers("phi_o");
  if (!f.phi_o.empty() && f.theta_o.empty()) n.fail("phi_o", "needs theta_o");
  if (n.has("theta_o_stride")) f.theta_o_stride = static_cast<int>(n.integer("theta_o_stride", 1, 1000000));
  if (n.has("theta_o_rows"))
    for (double r : n.numbers("theta_o_rows")) {
      if (r < 0 || r != std::floor(r) || r > 1e6) n.fail("theta_o_rows", format_number(r, "%g") + " is not a row index (0, 1, 2, ...)");
      f.theta_o_rows.push_back(static_cast<int>(r));
    }
  if (n.has("theta_o_deg")) {
    f.theta_o_deg = n.numbers("theta_o_deg");
    for (double d : f.theta_o_deg)
      if (!(d >= -90 && d <= 90)) n.fail("theta_o_deg", "angle " + format_number(d, "%g") + " deg is outside [-90, 90]");
  }
  return f;
}

}  // namespace bsdfmix
