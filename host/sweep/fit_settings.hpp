// The settings of a fit: how the sweep searches each slice's Gaussian count, fits the
// chosen K and refines it (the `fit:` section of a config, docs/fitting.md), where it
// writes, and which slices it fits. A plain value: the config parses it, the sweep reads it.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace bsdfmix {

// How the sweep searches each slice's Gaussian count, the `search` key of the fit section.
enum class SearchStrategy {
  Smem,      // smem: walk K upwards, each K grown from the last, with split-and-merge moves
  Restarts,  // restarts: independent k-means++ restarts per candidate K
};
// The config name of a strategy ("smem", "restarts").
const char* search_name(SearchStrategy s);
// The strategy a config name stands for; nullopt when it names none.
std::optional<SearchStrategy> search_strategy(const std::string& name);

// The criterion every fit chooses K by (sweep/criterion.hpp), as the files record it.
inline constexpr const char* kCriterion = "l1_rel + k_penalty * K";

struct FitSettings {
  std::string output, report, search_report;
  int k_min = 1, k_max = 32;
  std::uint64_t seed = 1;
  int restarts = 2, final_restarts = 4, iterations = 60, final_iterations = 300;
  double tolerance = 1e-6;
  int batch = 0;
  double k_penalty = 0.004;
  std::optional<double> error_target;
  int search_pool = 1;
  SearchStrategy search = SearchStrategy::Smem;
  std::string refine = "l1";    // l1: the final fits refined toward the least L1 error; none: EM's fits
  int refine_evaluations = 150;
  double refine_kl = 5.0;       // weight of the KL divergence (EM's objective) beside the L1 error
  double refine_rgb = 0.5;      // with colour: the R, G, B error's share of the refinement's L1 part; 0: luminance alone
  // with colour: a slice whose RGB error exceeds this times its luminance error gets colour
  // copies (docs/fitting.md, "Colour copies"); empty: none
  std::optional<double> rgb_copies = 1.2;
  // The plane the Gaussians live in (docs/fitting.md, "The map"): auto (chosen by a probe,
  // sweep/map_choice.hpp), equal_area (the disk on the hemisphere, the cylinder on the
  // fiber sphere) or theta_phi (files before maps).
  std::string map = "auto";
  std::vector<double> theta_o, phi_o;  // scene-driven slices; empty = all
  // Rows without radians (sweep/slice_plan.hpp plan_fit_slices), each adding its rows:
  // every Nth table row with the first and last (0: none), row indices, and degrees
  // snapped to the nearest row. None set and theta_o empty: every slice.
  int theta_o_stride = 0;
  std::vector<int> theta_o_rows;
  std::vector<double> theta_o_deg;
};

// Every field equal, paths and slices included.
bool operator==(const FitSettings& a, const FitSettings& b);
bool operator!=(const FitSettings& a, const FitSettings& b);
// The fields fit_settings_json (sweep/sweep.hpp) writes into files equal: every field but
// the output paths, the batch size and the slices.
bool same_result_settings(const FitSettings& a, const FitSettings& b);

}  // namespace bsdfmix
