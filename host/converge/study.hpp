// The Monte Carlo convergence study (docs/sampling.md): for each outgoing direction,
// scene and estimator, R runs of up to N_max samples in one launch; rows for
// N = 1, 2, 4, .., N_max of the convergence CSV, and the tail-risk CSV (both in
// docs/formats.md, "CSV files").
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "fit/em.hpp"
#include "sampling/sampling.hpp"
#include "sweep/fit_settings.hpp"

namespace bsdfmix {

struct StudySpec {
  std::string table, mixture;   // files
  std::string table_label;      // the CSV's `table` column
  std::vector<std::pair<double, double>> directions;  // (theta_o, phi_o), radians
  std::vector<Lighting> scenes;
  std::vector<Estimator> estimators;
  int runs = 64;
  std::uint64_t samples_max = 65536;  // a power of two
  std::uint64_t seed = 1;
  MisOptions mis;      // the MIS estimators' fractions and heuristic, the product's pruning
  bool product_auto = false;  // mis_product's fractions by tune_product_fractions, per direction and scene
  // product and mis_product: the lighting mixtures are fitted with these settings and
  // cached in light_cache_dir (scene/light_mixture.hpp), their engine run as light_engine says
  FitSettings light_fit;
  std::string light_cache_dir;
  EngineOptions light_engine;
  // The estimators that need one (kNeedsRgl): the RGL file (.bsdf) the table was imported
  // from (its source's sha256 must match); "" when no estimator needs one
  std::string rgl;
  std::string device;  // selector
  bool cpu = false;    // the CPU reference instead of the device kernels
  // Timed launches per estimator after the first, interleaved over the estimators (the
  // same launch shape): ns_per_sample is the fastest of them.
  int timing_rounds = 2;
  std::string csv, tail_csv, light_tail_csv;
};

struct ConvergenceRow {
  std::string table, scene, estimator;
  double theta_o = 0, phi_o = 0;
  std::uint64_t samples = 0;
  int runs = 0;
  double mean = 0, reference = 0, rmse = 0, rel_rmse = 0, ns_per_sample = 0;
  double uniform_fraction = 0;  // mis_tab's uniform share at this direction (every row of it)
};

constexpr const char* kConvergenceHeader =
    "table,theta_o,phi_o,scene,estimator,samples,runs,mean,reference,rmse,rel_rmse,ns_per_sample,uniform_fraction";
constexpr const char* kTailHeader =
    "table,theta_o,phi_o,k,l1_rel,reference,stand_in,stand_in_error,relvar_us,relvar_is,relvar_mis,"
    "max_weight_is,max_weight_mis,table_bytes,mixture_bytes,missed_is";

constexpr const char* kLightTailHeader =
    "table,theta_o,phi_o,scene,estimator,relvar,max_weight,missed,k_light,l1_light,light_fit_seconds,k_product,product_kept,product_fraction,product_light";

// Rows of one (direction, scene, estimator) from its run sums.
std::vector<ConvergenceRow> convergence_rows(const RunSums& sums, double reference, double ns_per_sample);
std::string format_row(const ConvergenceRow& r);

// Runs the study and writes both CSVs (atomically); returns the rows.
std::vector<ConvergenceRow> run_study(const StudySpec& spec);

}  // namespace bsdfmix
