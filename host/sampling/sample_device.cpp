// Device drivers of kernels/sample.cl: sampling, evaluation and the estimator launches.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>

#include "core/error.hpp"
#include "device/program.hpp"
#include "device/routine.hpp"
#include "device/shapes.hpp"
#include "sampling/sampling.hpp"

namespace bsdfmix {

namespace {

std::string domain_define(Domain d, mix::Map map) {
  return std::string(" -DHEMISPHERE=") + (d == Domain::Hemisphere ? "1" : "0") + " -DMAP=" +
         std::to_string(static_cast<int>(map)) + " -DPDF_LANES=" + std::to_string(QueryMixture::kLanes);
}

// device/routine.hpp's upload, an empty vector as 16 zeros (a kernel's absent input).
cl::Buffer upload(const Device& device, const std::vector<float>& v) {
  return bsdfmix::upload(device, "sampling input", v.empty() ? std::vector<float>(16, 0.f) : v);
}

// A launch of `items` work-items in work-groups of the device's item size (device/shapes.hpp).
void run_items(Routine& routine, const cl::CommandQueue& queue, const Device& device, std::size_t items) {
  const std::size_t group = item_group_size(device.info());
  routine.run(queue, cl::NDRange(item_global_size(items, group)), cl::NDRange(group));
}

}  // namespace

std::vector<mix::Sample> sample_device(const Device& device, const mix::MixtureSet& set, double theta_o,
                                       double phi_o, std::uint64_t seed, std::uint32_t stream, std::uint64_t first,
                                       std::size_t n) {
  const QueryMixture qm = make_query(set, theta_o, phi_o);
  std::vector<mix::Sample> out;
  out.reserve(n);
  if (n == 0) return out;
  cl::Program program = build_program(device, "sample", domain_define(qm.domain, qm.map));
  cl::CommandQueue queue = device.make_queue();
  cl::Buffer q = upload(device, qm.q), comps = upload(device, qm.comps), pdf = upload(device, qm.pdf);
  const std::size_t batch = std::min<std::size_t>(n, std::size_t(1) << 22);
  cl::Buffer res(device.context(), CL_MEM_WRITE_ONLY, batch * 4 * sizeof(float));
  Routine k(program, "sample_mixture");
  k.set("q", q).set("comps", comps).set("pd", pdf).set("key0", cl_uint(seed)).set("key1", cl_uint(seed >> 32))
      .set("stream", cl_uint(stream)).set("out", res);
  std::vector<float> host(batch * 4);
  for (std::size_t done = 0; done < n; done += batch) {
    const std::size_t m = std::min(batch, n - done);
    k.set("first", cl_ulong(first + done)).set("n", cl_uint(m));
    run_items(k, queue, device, m);
    queue.enqueueReadBuffer(res, CL_TRUE, 0, m * 4 * sizeof(float), host.data());
    for (std::size_t i = 0; i < m; ++i) {
      mix::Sample s;
      s.theta = host[4 * i];
      s.phi = host[4 * i + 1];
      s.pdf_omega = host[4 * i + 2];
      s.valid = host[4 * i + 3] > 0.5f;
      out.push_back(s);
    }
  }
  return out;
}

std::vector<std::pair<double, double>> eval_device(const Device& device, const mix::MixtureSet& set, double theta_o,
                                                   double phi_o, const std::vector<std::pair<double, double>>& dirs) {
  const QueryMixture qm = make_query(set, theta_o, phi_o);
  std::vector<std::pair<double, double>> out;
  if (dirs.empty()) return out;
  cl::Program program = build_program(device, "sample", domain_define(qm.domain, qm.map));
  cl::CommandQueue queue = device.make_queue();
  std::vector<float> d(dirs.size() * 2);
  for (std::size_t i = 0; i < dirs.size(); ++i) {
    d[2 * i] = float(dirs[i].first);
    d[2 * i + 1] = float(dirs[i].second);
  }
  cl::Buffer q = upload(device, qm.q), pdf = upload(device, qm.pdf), db = upload(device, d);
  cl::Buffer res(device.context(), CL_MEM_WRITE_ONLY, dirs.size() * 2 * sizeof(float));
  Routine k(program, "eval_mixture");
  k.set("q", q).set("pd", pdf).set("dirs", db).set("n", cl_uint(dirs.size())).set("out", res);
  run_items(k, queue, device, dirs.size());
  std::vector<float> host(dirs.size() * 2);
  queue.enqueueReadBuffer(res, CL_TRUE, 0, host.size() * sizeof(float), host.data());
  for (std::size_t i = 0; i < dirs.size(); ++i) out.emplace_back(host[2 * i], host[2 * i + 1]);
  return out;
}

namespace {

// One estimator launch of the convergence study: the program, the buffers and the
// argument list built once, so the launch can be timed more than once (timing rounds).
class IntegrateLaunch {
 public:
  IntegrateLaunch(const Device& device, const Problem& p, Estimator e, int runs, std::uint64_t n_max,
                  std::uint64_t seed, std::uint32_t chunk)
      : runs_(runs), n_max_(n_max), group_(item_group_size(device.info())) {
    if (n_max == 0 || (n_max & (n_max - 1)) != 0)
      throw ConfigError("integrate: the sample count must be a power of two");
    if (runs < 1) throw ConfigError("integrate: runs must be at least 1");
    if (!on_device(e))
      throw ConfigError(std::string("integrate: ") + estimator_name(e) + " has no kernel (run it with integrate_cpu)");
    chunk = std::uint32_t(std::min<std::uint64_t>(std::max<std::uint32_t>(chunk, 1), n_max));
    while (chunk & (chunk - 1)) chunk &= chunk - 1;
    chunk_ = chunk;
    chunks_ = n_max / chunk;
    if (chunks_ * std::uint64_t(runs) > 0xFFFFFFFFull) throw ConfigError("integrate: runs x chunks beyond 2^32");
    while ((std::uint32_t(1) << levels_) < chunk) ++levels_;

    // The kernel works in float. f (the table and the stand-in) enters every estimate
    // linearly, so it is divided by the power of two nearest the slice's largest value and
    // the sums are multiplied back in double: a table near FLT_MAX no longer overflows to
    // inf (and NaN in the compensated sums), one in the denormal range is no longer flushed
    // to zero, and for every other table the scaling is exact (the sums are bitwise the same).
    float f_max = 0.f;
    for (const float v : p.table.f) f_max = std::max(f_max, v);
    unit_ = f_max > 0.f && std::isfinite(f_max) ? std::ldexp(1.0, std::ilogb(f_max)) : 1.0;
    std::vector<float> f_dev(p.table.f.size());
    for (std::size_t i = 0; i < f_dev.size(); ++i) f_dev[i] = float(double(p.table.f[i]) / unit_);
    const QueryMixture scaled =
        unit_ == 1.0 || p.set == nullptr ? QueryMixture{} : make_query(*p.set, p.theta_o, p.phi_o, unit_);
    const QueryMixture& qm = unit_ == 1.0 || p.set == nullptr ? p.query : scaled;

    const std::string options = domain_define(p.table.domain, qm.map) + " -DESTIMATOR=" + std::to_string(int(e));
    cl::Program program = build_program(device, "sample", options);
    queue_ = device.make_queue();
    const cl::Context& ctx = device.context();
    items_ = std::size_t(chunks_) * std::size_t(runs);
    if (uses_product(e) && !p.has_product)
      throw ConfigError(std::string("integrate: ") + estimator_name(e) + " needs the lighting's mixture");
    sums_ = cl::Buffer(ctx, CL_MEM_WRITE_ONLY, items_ * sizeof(float));
    prefix_ = cl::Buffer(ctx, CL_MEM_WRITE_ONLY, std::max<std::size_t>(1, std::size_t(runs) * levels_) * sizeof(float));
    kernel_ = std::make_unique<Routine>(program, "integrate_chunks");
    kernel_->set("q", upload(device, qm.q)).set("comps", upload(device, qm.comps)).set("pd", upload(device, qm.pdf))
        .set("geo", upload(device, p.geometry())).set("f", upload(device, f_dev))
        .set("marg", upload(device, p.cdf.marginal)).set("cond", upload(device, p.cdf.conditional))
        .set("sc", upload(device, p.light.pack())).set("env", upload(device, p.light.env))
        .set("q2", upload(device, p.product_query.q)).set("comps2", upload(device, p.product_query.comps))
        .set("pd2", upload(device, p.product_query.pdf)).set("ls", upload(device, p.light_sampler.pack()))
        .set("key0", cl_uint(seed)).set("key1", cl_uint(seed >> 32)).set("stream", cl_uint(estimator_stream(int(e))))
        .set("levels", levels_).set("sums", sums_).set("prefix", prefix_);
  }

  // One timed launch of the full shape (runs x n_max samples); the first call is preceded
  // by an untimed warm-up launch (the same work-group size, a little work): device
  // compilers that specialize at the first enqueue do it there.
  double timed() {
    if (!warm_) {
      set_args(1, 1, std::min<cl_uint>(chunk_, 64));
      kernel_->run(queue_, cl::NDRange(group_), cl::NDRange(group_));
      queue_.finish();
      warm_ = true;
    }
    set_args(cl_uint(runs_), cl_uint(chunks_), chunk_);
    const auto t0 = std::chrono::steady_clock::now();
    kernel_->run(queue_, cl::NDRange(item_global_size(items_, group_)), cl::NDRange(group_));
    queue_.finish();
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }

  // The run sums of the last full launch.
  RunSums read() {
    RunSums rs;
    rs.runs = runs_;
    rs.levels = 1;
    while ((std::uint64_t(1) << (rs.levels - 1)) < n_max_) ++rs.levels;
    rs.sum.assign(std::size_t(runs_) * std::size_t(rs.levels), 0.0);
    std::vector<float> hs(items_), hp(std::size_t(runs_) * levels_);
    queue_.enqueueReadBuffer(sums_, CL_TRUE, 0, hs.size() * sizeof(float), hs.data());
    if (!hp.empty()) queue_.enqueueReadBuffer(prefix_, CL_TRUE, 0, hp.size() * sizeof(float), hp.data());
    for (int r = 0; r < runs_; ++r) {
      double acc = 0;
      std::uint64_t c = 0;
      for (int l = 0; l < rs.levels; ++l) {
        const std::uint64_t N = std::uint64_t(1) << l;
        double v;
        if (N < chunk_) {
          v = hp[std::size_t(r) * levels_ + std::size_t(l)];
        } else {
          while (c < N / chunk_) acc += hs[std::size_t(r) * chunks_ + c++];
          v = acc;
        }
        rs.sum[std::size_t(r) * std::size_t(rs.levels) + std::size_t(l)] = v * unit_;
      }
    }
    return rs;
  }

 private:
  void set_args(cl_uint n_runs, cl_uint n_chunks, cl_uint n_chunk) {
    kernel_->set("runs", n_runs).set("chunks", n_chunks).set("chunk", n_chunk);
  }

  int runs_;
  std::uint64_t n_max_, chunks_ = 0;
  std::uint32_t chunk_ = 0;
  cl_uint levels_ = 0;
  double unit_ = 1.0;
  std::size_t items_ = 0, group_;
  bool warm_ = false;
  cl::CommandQueue queue_;
  cl::Buffer sums_, prefix_;
  std::unique_ptr<Routine> kernel_;
};

}  // namespace

RunSums integrate_device(const Device& device, const Problem& p, Estimator e, int runs, std::uint64_t n_max,
                         std::uint64_t seed, std::uint32_t chunk) {
  IntegrateLaunch l(device, p, e, runs, n_max, seed, chunk);
  const double seconds = l.timed();
  RunSums rs = l.read();
  rs.seconds = seconds;
  return rs;
}

double time_integrate_device(const Device& device, const Problem& p, Estimator e, int runs, std::uint64_t n_max,
                             std::uint64_t seed, std::uint32_t chunk) {
  IntegrateLaunch l(device, p, e, runs, n_max, seed, chunk);
  return l.timed();
}

}  // namespace bsdfmix
