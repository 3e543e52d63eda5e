// The fit settings: the search strategies' names and the settings' comparisons.
#include "sweep/fit_settings.hpp"

#include <tuple>

namespace bsdfmix {

const char* search_name(SearchStrategy s) {
  switch (s) {
    case SearchStrategy::Smem: return "smem";
    case SearchStrategy::Restarts: return "restarts";
  }
  return "smem";
}

std::optional<SearchStrategy> search_strategy(const std::string& name) {
  for (SearchStrategy s : {SearchStrategy::Smem, SearchStrategy::Restarts})
    if (name == search_name(s)) return s;
  return std::nullopt;
}

namespace {

// The fields of same_result_settings, as one tuple of references.
auto result_fields(const FitSettings& f) {
  return std::tie(f.k_min, f.k_max, f.seed, f.restarts, f.final_restarts, f.iterations, f.final_iterations,
                  f.tolerance, f.k_penalty, f.error_target, f.search_pool, f.search, f.refine,
                  f.refine_evaluations, f.refine_kl, f.refine_rgb, f.rgb_copies, f.map);
}

}  // namespace

bool same_result_settings(const FitSettings& a, const FitSettings& b) { return result_fields(a) == result_fields(b); }

bool operator==(const FitSettings& a, const FitSettings& b) {
  return same_result_settings(a, b) &&
         std::tie(a.output, a.report, a.search_report, a.batch, a.theta_o, a.phi_o) ==
             std::tie(b.output, b.report, b.search_report, b.batch, b.theta_o, b.phi_o) &&
         std::tie(a.theta_o_stride, a.theta_o_rows, a.theta_o_deg) ==
             std::tie(b.theta_o_stride, b.theta_o_rows, b.theta_o_deg);
}

bool operator!=(const FitSettings& a, const FitSettings& b) { return !(a == b); }

}  // namespace bsdfmix
