// `bsdfmix recommend` (bench/sampler_choice.hpp): the candidates' weights at a few views,
// their relative variances, the choice and its CSV and text.
#include "bench/sampler_choice.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <sstream>
#include <thread>

#include "converge/quadrature.hpp"
#include "core/error.hpp"
#include "core/format.hpp"
#include "core/progress.hpp"
#include "fit/scheduler.hpp"
#include "io/mixture_file.hpp"
#include "io/table.hpp"
#include "scene/scene.hpp"
#include "tables/rgl_brdf.hpp"

namespace bsdfmix::bench {

namespace {

struct Candidate {
  const char* name;
  Peer peer;
  bool earned;  // mis_tab with the earned share
};

// The candidates under constant light (BSDF only) and under a scene, with or without the file.
std::vector<Candidate> candidates(bool scene, bool rgl) {
  std::vector<Candidate> c;
  if (scene) {
    c.push_back({"light", Peer::Light, false});
    c.push_back({"mis_light_gmm", Peer::MisLightGmm, false});
    c.push_back({"mis_light_cdf", Peer::MisLightCdf, false});
    if (rgl) c.push_back({"mis_light_rgl", Peer::MisLightRgl, false});
  }
  c.push_back({"is_tab", Peer::IsMixture, false});
  c.push_back({"mis_tab", Peer::MisMixture, false});
  c.push_back({"mis_tab", Peer::MisMixture, true});
  c.push_back({"cdf_tab", Peer::CdfTable, false});
  if (rgl) c.push_back({"is_rgl", Peer::Rgl, false});
  if (!scene) c.push_back({"us_tab", Peer::Uniform, false});
  return c;
}

double median_of(std::vector<double> v) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];  // the upper middle value, as fit and compare report
}

Lighting load_scene(const std::string& f, Domain domain) {
  YAML::Node node;
  try {
    node = YAML::LoadFile(f);
  } catch (const YAML::BadFile&) {
    throw InputError(f + ": cannot read scene file");
  } catch (const YAML::Exception& e) {
    throw InputError(f + ": " + e.what());
  }
  Lighting l = parse_scene(node, f, "", domain);
  l.domain = domain;
  return l;
}

void check_options(const SamplerChoiceOptions& o) {
  if (o.views < 1 || o.samples < 2 || o.quadrature < 8 || !(o.theta_max_deg > 0 && o.theta_max_deg < 90) ||
      !(o.light_fraction > 0 && o.light_fraction < 1))
    throw ConfigError("recommend: --views >= 1, --samples >= 2, --quadrature >= 8, 0 < --theta-max < 90, "
                      "0 < --light-fraction < 1");
}

// The figures of every candidate under every lighting, before the measurement.
void add_figures(SamplerChoice& out, const std::vector<Lighting>& lights, bool rgl, const SamplerChoiceOptions& o,
                 std::uint64_t table_bytes, std::uint64_t mixture_bytes) {
  for (std::size_t l = 0; l < lights.size(); ++l) {
    out.lightings.push_back(lights[l].name);
    out.references.push_back(l ? (rgl ? "mis_light_rgl" : "mis_light_cdf") : (rgl ? "is_rgl" : "cdf_tab"));
    for (const Candidate& c : candidates(l > 0, rgl)) {
      SamplerFigure f;
      f.lighting = lights[l].name;
      f.sampler = c.name;
      f.share = c.peer == Peer::MisMixture ? (c.earned ? "earned" : "0.1") : "";
      f.relvar.assign(out.views_deg.size(), 0.0);
      if (c.peer == Peer::Rgl || c.peer == Peer::MisLightRgl) f.bytes = std::uint64_t(std::filesystem::file_size(o.rgl));
      else if (c.peer == Peer::CdfTable || c.peer == Peer::MisLightCdf) f.bytes = table_bytes;
      else if (c.peer != Peer::Uniform && c.peer != Peer::Light) f.bytes = mixture_bytes;
      out.figures.push_back(f);
    }
  }
}

// Each figure's medians, its ratio to the lighting's reference, and the recommendation.
void summarise(SamplerChoice& out) {
  for (const std::string& lighting : out.lightings) {
    const std::string& reference = out.references[std::size_t(&lighting - out.lightings.data())];
    const SamplerFigure* ref = nullptr;
    for (const SamplerFigure& f : out.figures)
      if (f.lighting == lighting && f.sampler == reference) ref = &f;
    for (SamplerFigure& f : out.figures) {
      if (f.lighting != lighting) continue;
      f.median = median_of(f.relvar);
      f.max = *std::max_element(f.relvar.begin(), f.relvar.end());
      std::vector<double> ratio;
      for (std::size_t v = 0; v < f.relvar.size(); ++v) ratio.push_back(f.relvar[v] / ref->relvar[v]);
      f.vs_reference = median_of(ratio);
    }
    const int best = least_variance(out.figures, lighting);
    if (best >= 0) out.figures[std::size_t(best)].recommended = true;
  }
}

// The problems, per view and lighting with mis_tab's share fixed at 0.1 and earned
// ([view][lighting][earned]), and the integrals ([view][lighting]).
void make_problems(const SamplerChoice& out, const RglBrdf* brdf, const TableReader& table, const mix::MixtureSet& set,
                   const std::vector<Lighting>& lights, const SamplerChoiceOptions& o, std::vector<Problem>& problems,
                   std::vector<double>& integral) {
  const std::size_t nl = lights.size();
  std::vector<const Lighting*> lp;
  for (const Lighting& l : lights) lp.push_back(&l);
  for (std::size_t v = 0; v < out.views_deg.size(); ++v) {
    const double theta_o = out.views_deg[v] * mix::kPi / 180;
    const std::vector<double> rgl_i = brdf ? rgl_integrals(*brdf, theta_o, lp, o.quadrature) : std::vector<double>();
    for (std::size_t l = 0; l < nl; ++l)
      for (bool earned : {false, true}) {
        MisOptions mis;
        mis.earned = earned;
        mis.light_fraction = o.light_fraction;
        problems.push_back(make_problem(table, set, theta_o, 0.0, lights[l], mis, nullptr));
        if (!earned) integral.push_back(brdf ? rgl_i[l] : table_integral(problems.back()));
      }
  }
}

// Every figure's relative variance at every view, the tasks shared by the cores.
void measure(SamplerChoice& out, const RglBrdf* brdf, const std::vector<Problem>& problems,
             const std::vector<double>& integral, const SamplerChoiceOptions& o, const std::string& what) {
  struct Task {
    std::size_t figure, view, lighting;
    Peer peer;
    bool earned;
  };
  const std::size_t nl = out.lightings.size(), nv = out.views_deg.size();
  std::vector<Task> tasks;
  for (std::size_t i = 0, l = 0; l < nl; ++l)
    for (const Candidate& c : candidates(l > 0, brdf != nullptr)) {
      for (std::size_t v = 0; v < nv; ++v) tasks.push_back({i, v, l, c.peer, c.earned});
      ++i;
    }
  Progress progress("recommend " + what, tasks.size(), "runs");
  const unsigned threads = std::max(1u, std::min<unsigned>(std::thread::hardware_concurrency(), unsigned(tasks.size())));
  run_on_workers(tasks.size(), threads, [&](std::size_t, std::size_t t) {  // an error in any is rethrown here
    const Task& k = tasks[t];
    const Problem& p = problems[(k.view * nl + k.lighting) * 2 + (k.earned ? 1 : 0)];
    const WeightStats s = peer_stats(brdf, p, k.peer, o.seed, std::uint32_t(k.view), o.samples);
    out.figures[k.figure].relvar[k.view] = s.relvar(integral[k.view * nl + k.lighting]);
    progress.advance();
  });
  progress.finish();
}

}  // namespace

int least_variance(const std::vector<SamplerFigure>& figures, const std::string& lighting) {
  int best = -1;
  for (std::size_t i = 0; i < figures.size(); ++i)
    if (figures[i].lighting == lighting && (best < 0 || figures[i].median < figures[std::size_t(best)].median))
      best = int(i);
  return best;
}

SamplerChoice choose_sampler(const SamplerChoiceOptions& o) {
  check_options(o);
  const auto t0 = std::chrono::steady_clock::now();
  std::unique_ptr<RglBrdf> brdf;
  if (!o.rgl.empty()) brdf = std::make_unique<RglBrdf>(o.rgl);
  const TableReader table(o.table);
  const Domain domain = table.meta().domain;
  MixtureFile file = read_mixture_file(o.mixture);
  const mix::MixtureSet set = to_mixture_set(file);
  if (set.domain != domain)
    throw InputError(o.mixture + ": domain " + domain_name(set.domain) + " differs from the table's (" + o.table +
                     ": " + domain_name(domain) + ")");
  if (brdf && domain != Domain::Hemisphere) throw InputError(o.rgl + ": --rgl needs a hemisphere mixture and table");
  file.storage = MixtureStorage{true, true};  // as `bsdfmix pack` stores it by default

  std::vector<Lighting> lights{default_lighting(domain, 1.0)};
  lights[0].name = "constant";
  if (!o.scene.empty()) lights.push_back(load_scene(o.scene, domain));
  SamplerChoice out;
  out.samples = o.samples;
  for (int v = 0; v < o.views; ++v) out.views_deg.push_back((v + 0.5) * o.theta_max_deg / o.views);
  add_figures(out, lights, bool(brdf), o, table.meta().n_slices() * table.meta().cells_per_slice() * sizeof(float),
              file.payload_bytes());
  std::vector<Problem> problems;
  std::vector<double> integral;
  make_problems(out, brdf.get(), table, set, lights, o, problems, integral);
  measure(out, brdf.get(), problems, integral, o, std::filesystem::path(o.table).filename().string());
  summarise(out);
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

}  // namespace bsdfmix::bench
