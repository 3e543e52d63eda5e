// The path tracer: camera rays, vertices asked of their Bsdf, next-event estimation, MIS.
#include "render/integrator.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <mutex>
#include <thread>

#include "render/bsdf.hpp"

namespace bsdfmix {
namespace render {

namespace {

constexpr std::uint32_t kRenderStream = 0x72656e64u;  // "rend"

// Uniforms number `dim` of pixel p's sample s (four at a time).
struct Rng {
  std::uint64_t seed;
  std::uint32_t pixel, sample;
  void draw(std::uint32_t dim, double u[4]) const {
    const std::uint32_t ctr[4] = {pixel, sample, dim, kRenderStream};
    const std::uint32_t key[2] = {std::uint32_t(seed), std::uint32_t(seed >> 32)};
    const mix::PhiloxBlock r = mix::philox4x32_10(ctr, key);
    for (int i = 0; i < 4; ++i) u[i] = mix::to_uniform(r.v[i]);
  }
};

double power_weight(double a, double b) { return a * a / (a * a + b * b); }

// The light sample's density per steradian: light sampling alone, or at a fiber or a
// surface under mis_product the one-sample mixture of product sampling (share a) and
// light sampling (1 - a).
struct LightPdf {
  const LightSampler* light = nullptr;
  bool product = false;
  double share = 0;
  const FastProduct* prod = nullptr;
  LocalAxes axes;
  double operator()(const Vec3& w) const {
    const double pl = light->pdf(w);
    if (!product) return pl;
    double th, ph;
    local_angles(axes, w, th, ph);
    return share * prod->pdf_omega(axes.domain, th, ph) + (1 - share) * pl;
  }
};

// What a thread reuses from path to path: mis_product's two products (this vertex's and
// the one before's, whose density the next vertex's escaped ray needs), and the lighting
// ready to carry.
struct PathScratch {
  const CarrySource* carry = nullptr;
  FastProduct prod[2];
};

// A vertex of a training path: where it is, the direction it continued in (the guide's
// theta, phi), that direction's density, the vertex's f cos and own sampler's density
// there, the throughput at the next vertex before Russian roulette (luminance), and the
// path's luminance when it left the vertex. Plain data: a path's array is filled only
// while a guide trains.
struct TrainVertex {
  float position[3];
  float theta, phi;
  double pdf, beta, mark, f, pdf_bsdf;
};

// A path's training samples for the guide (guide/radiance_field.hpp), while it learns.
struct TrainPath {
  TrainVertex path[64];
  int recorded = 0, max_record = 0;
  // A vertex at `depth`: the rest is filled when the path continues.
  void start(int depth, const Vec3& position) {
    if (depth >= max_record) return;
    TrainVertex& tv = path[recorded++];
    for (int i = 0; i < 3; ++i) tv.position[i] = float(position[std::size_t(i)]);
    tv.theta = tv.phi = 0;
    tv.pdf = tv.beta = tv.mark = tv.f = tv.pdf_bsdf = 0;
  }
  void continued(int depth, const Vec3& wi, double pdf, const Rgb& fv, double pdf_bsdf, const Rgb& beta, const Rgb& L) {
    if (depth >= max_record) return;
    TrainVertex& tv = path[recorded - 1];
    double th, ph;
    guide::guide_angles(wi, th, ph);
    tv.theta = float(th);
    tv.phi = float(ph);
    tv.pdf = pdf;
    tv.f = fv.luminance();
    tv.pdf_bsdf = pdf_bsdf;
    tv.beta = beta.luminance();
    tv.mark = L.luminance();
  }
  // Each recorded vertex's sample: the luminance that arrived along its direction (all the
  // path gathered after it, over the throughput there) over the direction's density.
  void emit(const Rgb& L, std::vector<guide::Sample>& train) const {
    const double end = L.luminance();
    for (int i = 0; i < recorded; ++i) {
      const TrainVertex& tv = path[i];
      guide::Sample s;
      std::copy(tv.position, tv.position + 3, s.position);
      s.theta = tv.theta;
      s.phi = tv.phi;
      s.radiance = tv.beta > 0 ? float((end - tv.mark) / tv.beta) : 0.f;
      s.pdf = float(tv.pdf);
      s.f = float(tv.f);
      s.pdf_bsdf = float(tv.pdf_bsdf);
      train.push_back(s);
    }
  }
};

int thread_count(int asked) {
  if (asked > 0) return asked;
  const unsigned n = std::thread::hardware_concurrency();
  return n > 0 ? int(n) : 1;
}

// The guide at a vertex: its leaf's mixture over world directions (share a_guide) and,
// under guided_product at a fiber or surface, the product of its compact part carried
// into the hit's frame with the BSDF mixture (share a_prod); the BSDF's draw has the rest.
struct Guiding {
  const guide::Leaf* leaf = nullptr;
  LocalAxes axes;  // the hit's frame, where guided_product carries the leaf
  mix::SliceMixture gprod;
  double a_prod = 0, a_guide = 0;
  // The density of the next direction, whoever draws it.
  double pdf(const Bsdf& b, const Vec3& w) const {
    if (!leaf) return b.pdf(w);
    double p = (1 - a_guide - a_prod) * b.pdf(w), th, ph;
    if (a_guide > 0) {
      guide::guide_angles(w, th, ph);
      p += a_guide * leaf->mixture.pdf_omega(Domain::Fiber, th, ph);
    }
    if (a_prod > 0) {
      local_angles(axes, w, th, ph);
      p += a_prod * gprod.pdf_omega(axes.domain, th, ph);
    }
    return p;
  }
};

Guiding guiding_at(const SceneView& v, const PathStrategy& st, int depth, const Vec3& position, const Bsdf& b) {
  Guiding g;
  g.leaf = st.guided && v.guide && depth < v.guide_depth ? v.guide->at(position) : nullptr;
  if (!g.leaf) return g;
  g.a_guide = g.leaf->share;
  if (st.guided_product && b.tabulated() && !g.leaf->compact.empty() && g.a_guide > 0) {
    g.axes = b.axes();
    try {
      const mix::SliceMixture lobes = carry_lighting(g.leaf->compact, g.axes, kGuideAxes, v.bsdf->map());
      g.gprod = v.bsdf->product(b.theta_o(), lobes, v.product);
      g.a_prod = g.a_guide * g.leaf->compact_share;
      g.a_guide -= g.a_prod;
    } catch (const std::invalid_argument&) {
      // no overlap: the leaf's mixture alone
    }
  }
  return g;
}

// The radiance and throughput of a path so far, and what its next vertex needs of the
// last: the density of its direction, whether light samples were taken there, and the
// light sample's density at this vertex and at the one before (with mis_product's two
// products: this vertex's and the one before's, whose density the escaped ray needs).
struct PathState {
  Rgb L, beta{1.0};
  double prev_pdf = 0;
  bool prev_nee = false;
  LightPdf lp, prev_lp;
  FastProduct *cur = nullptr, *prev = nullptr;
};

// The ray leaving a hit: off a fiber past its own radius, off a surface's float triangles.
Ray spawn_ray(const Hit& hit, double fiber_radius) {
  Ray next;
  next.org = hit.position;
  if (hit.kind == HitKind::Fiber) {
    next.from_fiber = hit.fiber;
    next.skip = 4 * fiber_radius;
  } else {
    next.tnear = hit.kind == HitKind::Surface ? 1e-4 : 1e-6;
  }
  return next;
}

// Next-event estimation: a light sample (from the lighting, or under mis_product at a
// tabulated material from the product with the lighting carried into the hit's frame),
// combined with the vertex's own draw by the power heuristic.
void next_event(const SceneView& v, bool product, const CarrySource& carry, const Rng& rng, std::uint32_t dim,
                const Bsdf& b, const Guiding& g, const Ray& next, PathState& s, std::uint64_t& rays) {
  double u[4];
  rng.draw(dim + 1, u);
  LightPdf& lp = s.lp;
  lp.product = false;
  if (product && b.tabulated()) {
    lp.axes = b.axes();
    // no overlap: light sampling alone
    lp.product = s.cur->build(v.bsdf->product_factor(b.theta_o()), carry, lp.axes, v.product);
    lp.prod = s.cur;
  }
  Vec3 wl;
  bool drawn = true;
  if (lp.product && u[0] < lp.share) {
    const mix::Sample m = lp.prod->sample(lp.axes.domain, u[0] / lp.share, u[1], u[2]);
    drawn = m.valid;
    if (drawn) wl = local_direction(lp.axes, m.theta, m.phi);
  } else {
    const double u0 = lp.product ? (u[0] - lp.share) / (1 - lp.share) : u[0];
    wl = v.light->sample(std::min(u0, 1 - 1e-12), u[1], u[2], u[3]);
  }
  const double pl = drawn ? lp(wl) : 0.0;
  const Rgb fv = pl > 0 ? b.f(wl) : Rgb();
  if (fv.max() > 0) {
    Ray shadow = next;
    shadow.dir = wl;
    ++rays;
    if (!v.tracer->occluded(shadow))
      s.L += s.beta * fv * v.lighting->radiance_world(wl) * power_weight(pl, g.pdf(b, wl)) / pl;
  }
}

// The next direction and its density (the guide's draw or the vertex's own); ur[0] the
// Russian roulette's uniform, ur[1] the guide's technique (drawn where either is needed).
// False: the path ends.
bool next_direction(const Rng& rng, std::uint32_t dim, bool roulette, const Bsdf& b, const Guiding& g, Vec3& wi,
                    double& pdf, double ur[4]) {
  double u[4];
  rng.draw(dim + 2, u);
  if (g.leaf || roulette) rng.draw(dim + 3, ur);
  if (g.leaf && ur[1] < g.a_guide + g.a_prod) {
    const bool from_product = ur[1] < g.a_prod;
    const mix::Sample m = from_product ? g.gprod.sample(g.axes.domain, u[0], u[1], u[2])
                                       : g.leaf->mixture.sample(Domain::Fiber, u[0], u[1], u[2]);
    if (!m.valid) return false;
    wi = from_product ? local_direction(g.axes, m.theta, m.phi) : guide::guide_direction(m.theta, m.phi);
    pdf = g.pdf(b, wi);
    return pdf > 0;
  }
  if (!b.sample(u, wi, pdf)) return false;
  if (g.leaf) pdf = g.pdf(b, wi);
  return true;
}

// One path: the RGB radiance arriving at the camera along `ray`, the throughput carried
// per channel (directions are drawn by the luminance samplers; every decision reads the
// largest channel, so a grey path is exactly the luminance path). At each vertex the hit's
// Bsdf (render/bsdf.hpp) gives f, the draw and its density, as the estimator's strategy
// (sampling/estimator.hpp) has it drawn. `theta_out`, when given, receives theta_o of
// every fiber or surface vertex (the pre-pass); `train`, when given, the path's training
// samples for the guide (guide/radiance_field.hpp).
Rgb trace_path(const SceneView& v, PathEstimator est, FSource which, Ray ray, const Rng& rng, std::uint64_t& rays,
               std::uint64_t& vertices, std::vector<double>* theta_out, std::vector<guide::Sample>* train,
               PathScratch& scratch) {
  const PathStrategy& st = path_strategy(est);
  const SampledBxdf material(*v.bsdf, which, st);
  const bool product = st.product && scratch.carry && !scratch.carry->empty();
  VertexBsdf held;
  TrainPath tp;
  tp.max_record = train ? std::min(v.max_depth, 64) : 0;
  PathState s;
  s.cur = &scratch.prod[0];
  s.prev = &scratch.prod[1];
  s.lp.light = s.prev_lp.light = v.light;
  s.lp.share = s.prev_lp.share = v.product_share;
  for (int depth = 0; depth < v.max_depth; ++depth) {
    const Hit hit = v.tracer->intersect(ray);
    ++rays;
    if (hit.kind == HitKind::None) {
      const double Le = v.lighting->radiance_world(ray.dir);  // the lighting is grey
      if (!s.prev_nee) s.L += s.beta * Le;
      else if (s.prev_pdf > 0) s.L += s.beta * Le * power_weight(s.prev_pdf, s.prev_lp(ray.dir));
      break;
    }
    tp.start(depth, hit.position);
    ++vertices;
    const std::uint32_t dim = std::uint32_t(depth) * 4;
    const Bsdf& b = held.at(hit, neg(ray.dir), material, v.ground_albedo);
    if (b.tabulated() && theta_out) theta_out->push_back(b.theta_o());
    const Guiding g = guiding_at(v, st, depth, hit.position, b);
    Ray next = spawn_ray(hit, v.fiber_radius);
    if (st.light_sampling) next_event(v, product, *scratch.carry, rng, dim, b, g, next, s, rays);
    Vec3 wi;
    double pdf = 0, ur[4] = {0, 0, 0, 0};
    if (!next_direction(rng, dim, depth + 1 >= v.rr_depth, b, g, wi, pdf, ur)) break;
    const Rgb fv = b.f(wi);
    if (!(fv.max() > 0)) break;
    s.beta *= fv / pdf;
    if (depth < tp.max_record) tp.continued(depth, wi, pdf, fv, g.leaf ? b.pdf(wi) : pdf, s.beta, s.L);
    if (depth + 1 >= v.rr_depth) {
      const double q = std::min(0.95, s.beta.max());
      if (ur[0] >= q) break;
      s.beta /= q;
    }
    s.prev_pdf = pdf;
    s.prev_nee = st.light_sampling;
    if (st.light_sampling) {  // the product this vertex built stays with prev_lp; the next one builds into the other buffer
      std::swap(s.prev_lp, s.lp);
      std::swap(s.cur, s.prev);
    }
    next.dir = wi;
    ray = next;
  }
  if (train) tp.emit(s.L, *train);
  return s.L;
}

}  // namespace

Ray camera_ray(const Camera& c, int width, int height, double x, double y) {
  const Vec3 f = normalized({c.look_at[0] - c.position[0], c.look_at[1] - c.position[1], c.look_at[2] - c.position[2]});
  const Vec3 r = normalized(cross(f, c.up));
  const Vec3 up = cross(r, f);
  const double t = std::tan(0.5 * c.fov_deg * kPi / 180), aspect = double(width) / double(height);
  const double sx = (2 * x / width - 1) * t * aspect, sy = (1 - 2 * y / height) * t;
  Ray ray;
  ray.org = c.position;
  ray.dir = normalized({f[0] + sx * r[0] + sy * up[0], f[1] + sx * r[1] + sy * up[1], f[2] + sx * r[2] + sy * up[2]});
  return ray;
}

std::vector<std::uint8_t> material_mask(const SceneView& v) {
  std::vector<std::uint8_t> mask(std::size_t(v.width) * std::size_t(v.height), 0);
  for (int y = 0; y < v.height; ++y)
    for (int x = 0; x < v.width; ++x) {
      const HitKind k = v.tracer->intersect(camera_ray(v.camera, v.width, v.height, x + 0.5, y + 0.5)).kind;
      mask[std::size_t(y) * std::size_t(v.width) + std::size_t(x)] = k == HitKind::Fiber || k == HitKind::Surface;
    }
  return mask;
}

RenderStats render_passes(const SceneView& v, PathEstimator est, FSource which, int first, int max_passes,
                          std::vector<double>& sum, const std::function<bool(int, double)>& pass_done) {
  const std::size_t pixels = std::size_t(v.width) * std::size_t(v.height);
  sum.resize(3 * pixels, 0.0);
  RenderStats st;
  const auto t0 = std::chrono::steady_clock::now();
  const int nt = thread_count(v.threads);
  // mis_product's lighting, ready to carry into each hit's frame
  const CarrySource carry = v.world_light ? CarrySource(*v.world_light) : CarrySource();
  for (int pass = first; pass < first + max_passes; ++pass) {
    std::atomic<int> next_row{0};
    std::atomic<std::uint64_t> rays{0}, vertices{0};
    auto work = [&]() {
      std::uint64_t local = 0, local_vertices = 0;
      PathScratch scratch;
      scratch.carry = &carry;
      for (int y = next_row++; y < v.height; y = next_row++)
        for (int x = 0; x < v.width; ++x) {
          const std::uint32_t p = std::uint32_t(y * v.width + x);
          const Rng rng{v.seed, p, std::uint32_t(pass)};
          double u[4];
          rng.draw(0, u);
          const Ray ray = camera_ray(v.camera, v.width, v.height, x + u[0], y + u[1]);
          const Rgb L = trace_path(v, est, which, ray, rng, local, local_vertices, nullptr,
                                   v.train ? &(*v.train)[std::size_t(y)] : nullptr, scratch);
          for (int c = 0; c < 3; ++c) sum[3 * std::size_t(p) + std::size_t(c)] += L[c];
        }
      rays += local;
      vertices += local_vertices;
    };
    std::vector<std::thread> pool;
    for (int i = 1; i < nt; ++i) pool.emplace_back(work);
    work();
    for (auto& t : pool) t.join();
    st.rays += rays;
    st.vertices += vertices;
    st.threads = nt;
    st.spp = pass - first + 1;
    st.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (pass_done && !pass_done(st.spp, st.seconds)) break;
  }
  return st;
}

std::vector<double> collect_theta_o(const SceneView& v, int spp) {
  std::vector<double> out;
  std::mutex m;
  const int nt = thread_count(v.threads);
  std::atomic<int> next_row{0};
  auto work = [&]() {
    std::vector<double> local;
    std::uint64_t rays = 0, vertices = 0;
    PathScratch scratch;  // uniform sampling: no product
    for (int y = next_row++; y < v.height; y = next_row++)
      for (int x = 0; x < v.width; ++x)
        for (int s = 0; s < spp; ++s) {
          const Rng rng{v.seed ^ 0x9e3779b97f4a7c15ull, std::uint32_t(y * v.width + x), std::uint32_t(s)};
          double u[4];
          rng.draw(0, u);
          trace_path(v, PathEstimator::Uniform, FSource::Table, camera_ray(v.camera, v.width, v.height, x + u[0], y + u[1]),
                     rng, rays, vertices, &local, nullptr, scratch);
        }
    std::lock_guard<std::mutex> lock(m);
    out.insert(out.end(), local.begin(), local.end());
  };
  std::vector<std::thread> pool;
  for (int i = 1; i < nt; ++i) pool.emplace_back(work);
  work();
  for (auto& t : pool) t.join();
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace render
}  // namespace bsdfmix
