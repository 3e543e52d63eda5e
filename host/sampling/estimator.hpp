// The estimators of the convergence study and of the renderer as one list (docs/sampling.md,
// docs/render.md, "Estimators"): each a strategy in its own file (host/sampling/estimator_*.cpp),
// named in the registry (host/sampling/estimator_registry.cpp) with the draws it combines, what
// it needs (the lighting, the lighting's product, the RGL file, a learned guide), its id in
// kernels/sample.cl if the kernel implements it, its part in the study (one estimate from four
// uniforms, its density, its draw) and its part in the renderer (which technique draws a path's
// next direction at a material, whether light samples join it by MIS).
#pragma once

#include <deque>
#include <string>

namespace bsdfmix {

struct Problem;
namespace render {
class TableBsdf;
}

// The estimators' ids: kernels/sample.cl numbers the ones it implements (ESTIMATOR, 0 .. 10)
// as this enum does. Registered estimators take the ids from kBuiltinEstimators on.
enum class Estimator {
  UsTab = 0, UsGmm = 1, IsTab = 2, IsGmm = 3, MisTab = 4, CdfTab = 5,
  Light = 6, MisLightCdf = 7, MisLightGmm = 8, Product = 9, MisProduct = 10,
  IsRgl = 11, MisLightRgl = 12,
  // the renderer's alone
  Uniform = 13, Guided = 14, GuidedProduct = 15
};
constexpr int kBuiltinEstimators = 16;

// What an estimator needs besides the table and its mixtures.
enum EstimatorNeeds : unsigned {
  kNeedsLighting = 1u,  // its draw depends on the lighting (light sampling, the product)
  kNeedsProduct = 2u,   // the lighting's fitted mixture (the study's product sampling)
  kNeedsRgl = 4u,       // the RGL file the (hemisphere) table was imported from
  kNeedsGuide = 8u,     // a learned incident radiance (guide/radiance_field.hpp)
  kStandInF = 16u,      // it integrates the stand-in's f, not the table's (us_gmm, is_gmm)
};

// The study's part: one estimate of the integral of L_i f c over the domain from the
// uniforms u (double; the reference of kernels/sample.cl `estimate`), the density per
// steradian with which it draws (theta, phi) (world phi; the MIS estimators' combined one),
// and its draw (false: none). `draw` is null for the one-sample MIS estimators.
struct StudyStrategy {
  double (*estimate)(const Problem& p, const double u[4]) = nullptr;
  double (*pdf)(const Problem& p, double theta, double phi) = nullptr;
  bool (*draw)(const Problem& p, const double u[4], double& theta, double& phi) = nullptr;
};

// The techniques a material (render::TableBsdf) draws a direction with in its own frame:
// uniform over the domain, the mixture with a defensive uniform share, the table's CDF,
// the RGL file's warps.
enum class BsdfSampler { Uniform, Mixture, TableCdf, Rgl };

// A draw of an estimator's own at a path's material vertex, in the material's local frame
// for omega_o at theta_o (phi from the plane of omega_o): a direction from u[0..3] and its
// density per steradian (pdf 0: none), and that density at a direction.
class VertexSampler {
 public:
  virtual ~VertexSampler() = default;
  virtual void sample(const render::TableBsdf& m, double theta_o, const double u[4], double& theta, double& phi,
                      double& pdf) const = 0;
  virtual double pdf(const render::TableBsdf& m, double theta_o, double theta, double phi) const = 0;
};

// The renderer's part (render/integrator.cpp): the draw of the next direction at a
// material (one of its techniques, or `sampler` when set), and what joins it.
struct PathStrategy {
  bool renders = false;  // the renderer offers it
  BsdfSampler technique = BsdfSampler::Uniform;
  const VertexSampler* sampler = nullptr;  // an estimator's own draw (not owned)
  bool light_sampling = false;  // next-event estimation, combined with the BSDF sample by MIS
  bool product = false;         // light samples from the lighting x BSDF mixture product too
  bool guided = false;          // the guide's mixture draws a share of the directions ...
  bool guided_product = false;  // ... and its product with the BSDF mixture another
};

struct EstimatorInfo {
  std::string name;   // in configs and CSVs
  std::string draws;  // the draws it combines, in words
  unsigned needs = 0;
  int device_id = -1;  // its ESTIMATOR in kernels/sample.cl; -1: the CPU alone
  StudyStrategy study;  // estimate null: not in the study
  PathStrategy render;
  Estimator id = Estimator::UsTab;  // set by the registry
  bool in_study() const { return study.estimate != nullptr; }
};

// Adds an estimator (its name must be new; no device_id: kernels/sample.cl implements the
// built-in ones alone) and returns its id. Register before a study or a render starts: the
// list is read without a lock.
Estimator register_estimator(EstimatorInfo info);
// Every estimator, the built-in ones in their listing order, then the registered ones (a
// deque: the references it hands out stay valid as estimators are added).
const std::deque<EstimatorInfo>& estimators();
// Throws std::out_of_range for an id nobody registered.
const EstimatorInfo& estimator_info(Estimator e);
// nullptr for an unknown name.
const EstimatorInfo* find_estimator(const std::string& name);

// The names of the study's estimators ("us_tab, us_gmm, .. or mis_light_rgl") and of the
// renderer's ("uniform, mis_tab, .. or mis_light_rgl").
std::string estimator_list();
std::string path_estimator_list();

inline bool on_device(Estimator e) { return estimator_info(e).device_id >= 0; }
inline bool has_need(Estimator e, unsigned need) { return (estimator_info(e).needs & need) != 0; }
// The estimators that sample by the lighting mixture's product (they need one fitted).
inline bool uses_product(Estimator e) { return has_need(e, kNeedsProduct); }
// The estimators that draw with the RGL file's own warps (Problem::rgl).
inline bool rgl_estimator(Estimator e) { return has_need(e, kNeedsRgl); }
// The estimators whose draw depends on the lighting (light sampling, the product).
inline bool uses_lighting(Estimator e) { return has_need(e, kNeedsLighting); }
inline bool uses_table(Estimator e) { return !has_need(e, kStandInF); }
const char* estimator_name(Estimator e);
// A study estimator by name; throws ConfigError naming `where` for an unknown name.
Estimator parse_estimator(const std::string& name, const std::string& where);

}  // namespace bsdfmix
