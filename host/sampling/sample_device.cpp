// Device drivers of kernels/sample.cl: sampling, evaluation and the estimator launches.
#include <algorithm>
#include <chrono>
#include <cmath>

#include "core/error.hpp"
#include "device/program.hpp"
#include "sampling/sampling.hpp"

namespace bsdfmix {

namespace {

std::string domain_define(Domain d) { return std::string(" -DHEMISPHERE=") + (d == Domain::Hemisphere ? "1" : "0"); }

cl::Buffer upload(const Device& device, const std::vector<float>& v) {
  std::vector<float> data = v.empty() ? std::vector<float>(16, 0.f) : v;
  return cl::Buffer(device.context(), CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, data.size() * sizeof(float),
                    data.data());
}

constexpr std::size_t kLocal = 64;
std::size_t padded(std::size_t n) { return (n + kLocal - 1) / kLocal * kLocal; }

}  // namespace

std::vector<mix::Sample> sample_device(const Device& device, const mix::MixtureSet& set, double theta_o,
                                       double phi_o, std::uint64_t seed, std::uint32_t stream, std::uint64_t first,
                                       std::size_t n) {
  const QueryMixture qm = make_query(set, theta_o, phi_o);
  std::vector<mix::Sample> out;
  out.reserve(n);
  if (n == 0) return out;
  cl::Program program = build_program(device, "sample", domain_define(qm.domain));
  cl::CommandQueue queue = device.make_queue();
  cl::Buffer q = upload(device, qm.q), comps = upload(device, qm.comps);
  const std::size_t batch = std::min<std::size_t>(n, std::size_t(1) << 22);
  cl::Buffer res(device.context(), CL_MEM_WRITE_ONLY, batch * 4 * sizeof(float));
  cl::Kernel k(program, "sample_mixture");
  std::vector<float> host(batch * 4);
  for (std::size_t done = 0; done < n; done += batch) {
    const std::size_t m = std::min(batch, n - done);
    k.setArg(0, q);
    k.setArg(1, comps);
    k.setArg(2, cl_uint(seed));
    k.setArg(3, cl_uint(seed >> 32));
    k.setArg(4, cl_uint(stream));
    k.setArg(5, cl_ulong(first + done));
    k.setArg(6, cl_uint(m));
    k.setArg(7, res);
    launch(queue, k, "sample_mixture", cl::NDRange(padded(m)), cl::NDRange(kLocal));
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
  cl::Program program = build_program(device, "sample", domain_define(qm.domain));
  cl::CommandQueue queue = device.make_queue();
  std::vector<float> d(dirs.size() * 2);
  for (std::size_t i = 0; i < dirs.size(); ++i) {
    d[2 * i] = float(dirs[i].first);
    d[2 * i + 1] = float(dirs[i].second);
  }
  cl::Buffer q = upload(device, qm.q), comps = upload(device, qm.comps), db = upload(device, d);
  cl::Buffer res(device.context(), CL_MEM_WRITE_ONLY, dirs.size() * 2 * sizeof(float));
  cl::Kernel k(program, "eval_mixture");
  k.setArg(0, q);
  k.setArg(1, comps);
  k.setArg(2, db);
  k.setArg(3, cl_uint(dirs.size()));
  k.setArg(4, res);
  launch(queue, k, "eval_mixture", cl::NDRange(padded(dirs.size())), cl::NDRange(kLocal));
  std::vector<float> host(dirs.size() * 2);
  queue.enqueueReadBuffer(res, CL_TRUE, 0, host.size() * sizeof(float), host.data());
  for (std::size_t i = 0; i < dirs.size(); ++i) out.emplace_back(host[2 * i], host[2 * i + 1]);
  return out;
}

RunSums integrate_device(const Device& device, const Problem& p, Estimator e, int runs, std::uint64_t n_max,
                         std::uint64_t seed, std::uint32_t chunk) {
  if (n_max == 0 || (n_max & (n_max - 1)) != 0) throw ConfigError("integrate: the sample count must be a power of two");
  if (runs < 1) throw ConfigError("integrate: runs must be at least 1");
  chunk = std::uint32_t(std::min<std::uint64_t>(std::max<std::uint32_t>(chunk, 1), n_max));
  while (chunk & (chunk - 1)) chunk &= chunk - 1;
  const std::uint64_t chunks = n_max / chunk;
  if (chunks * std::uint64_t(runs) > 0xFFFFFFFFull) throw ConfigError("integrate: runs x chunks beyond 2^32");
  cl_uint in_chunk_levels = 0;
  while ((std::uint32_t(1) << in_chunk_levels) < chunk) ++in_chunk_levels;

  RunSums rs;
  rs.runs = runs;
  rs.levels = 1;
  while ((std::uint64_t(1) << (rs.levels - 1)) < n_max) ++rs.levels;
  rs.sum.assign(std::size_t(runs) * std::size_t(rs.levels), 0.0);

  // The kernel works in float. f (the table and the stand-in) enters every estimate
  // linearly, so it is divided by the power of two nearest the slice's largest value and
  // the sums are multiplied back in double: a table near FLT_MAX no longer overflows to
  // inf (and NaN in the compensated sums), one in the denormal range is no longer flushed
  // to zero, and for every other table the scaling is exact (the sums are bitwise the same).
  float f_max = 0.f;
  for (const float v : p.table.f) f_max = std::max(f_max, v);
  const double unit = f_max > 0.f && std::isfinite(f_max) ? std::ldexp(1.0, std::ilogb(f_max)) : 1.0;
  std::vector<float> f_dev(p.table.f.size());
  for (std::size_t i = 0; i < f_dev.size(); ++i) f_dev[i] = float(double(p.table.f[i]) / unit);
  const std::vector<float> comps_dev =
      unit == 1.0 || p.set == nullptr ? p.query.comps : make_query(*p.set, p.theta_o, p.phi_o, unit).comps;

  const std::string options = domain_define(p.table.domain) + " -DESTIMATOR=" + std::to_string(int(e));
  cl::Program program = build_program(device, "sample", options);
  cl::CommandQueue queue = device.make_queue();
  const cl::Context& ctx = device.context();
  cl::Buffer q = upload(device, p.query.q), comps = upload(device, comps_dev), geo = upload(device, p.geometry()),
             f = upload(device, f_dev), marg = upload(device, p.cdf.marginal),
             cond = upload(device, p.cdf.conditional), sc = upload(device, p.light.pack()),
             env = upload(device, p.light.env);
  const std::size_t items = std::size_t(chunks) * std::size_t(runs);
  cl::Buffer sums(ctx, CL_MEM_WRITE_ONLY, items * sizeof(float));
  cl::Buffer prefix(ctx, CL_MEM_WRITE_ONLY, std::max<std::size_t>(1, std::size_t(runs) * in_chunk_levels) * sizeof(float));
  cl::Kernel k(program, "integrate_chunks");
  auto set_args = [&](cl_uint n_runs, cl_uint n_chunks, cl_uint n_chunk) {
    k.setArg(0, q);
    k.setArg(1, comps);
    k.setArg(2, geo);
    k.setArg(3, f);
    k.setArg(4, marg);
    k.setArg(5, cond);
    k.setArg(6, sc);
    k.setArg(7, env);
    k.setArg(8, cl_uint(seed));
    k.setArg(9, cl_uint(seed >> 32));
    k.setArg(10, cl_uint(estimator_stream(int(e))));
    k.setArg(11, n_runs);
    k.setArg(12, n_chunks);
    k.setArg(13, n_chunk);
    k.setArg(14, in_chunk_levels);
    k.setArg(15, sums);
    k.setArg(16, prefix);
  };
  // Warm-up launch (the same work-group size, a little work): device compilers that
  // specialize at the first enqueue do it here, outside the timed launch.
  set_args(1, 1, std::min<cl_uint>(chunk, 64));
  launch(queue, k, "integrate_chunks", cl::NDRange(kLocal), cl::NDRange(kLocal));
  queue.finish();
  set_args(cl_uint(runs), cl_uint(chunks), chunk);
  const auto t0 = std::chrono::steady_clock::now();
  launch(queue, k, "integrate_chunks", cl::NDRange(padded(items)), cl::NDRange(kLocal));
  queue.finish();
  rs.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::vector<float> hs(items), hp(std::size_t(runs) * in_chunk_levels);
  queue.enqueueReadBuffer(sums, CL_TRUE, 0, hs.size() * sizeof(float), hs.data());
  if (!hp.empty()) queue.enqueueReadBuffer(prefix, CL_TRUE, 0, hp.size() * sizeof(float), hp.data());
  for (int r = 0; r < runs; ++r) {
    double acc = 0;
    std::uint64_t c = 0;
    for (int l = 0; l < rs.levels; ++l) {
      const std::uint64_t N = std::uint64_t(1) << l;
      double v;
      if (N < chunk) {
        v = hp[std::size_t(r) * in_chunk_levels + std::size_t(l)];
      } else {
        while (c < N / chunk) acc += hs[std::size_t(r) * chunks + c++];
        v = acc;
      }
      rs.sum[std::size_t(r) * std::size_t(rs.levels) + std::size_t(l)] = v * unit;
    }
  }
  return rs;
}

}  // namespace bsdfmix
