// The amplitude fit's sums on the devices: kernels/em.cl amp_basis and amp_sums, batched by K bucket.
#include <algorithm>
#include <cmath>
#include <map>

#include "core/error.hpp"
#include "device/program.hpp"
#include "fit/em.hpp"
#include "fit/em_internal.hpp"
#include "fit/scheduler.hpp"

namespace bsdfmix {

using namespace em_detail;

EmEngine::AmpSlices EmEngine::amp_prepare(const ChannelSet& set) {
  if (set.channels < 1 || set.channels > kMaxChannels)
    throw ConfigError("amplitude fit: " + std::to_string(set.channels) + " channels, expected 1.." +
                      std::to_string(kMaxChannels));
  SliceSet grid_only;
  grid_only.grid = set.grid;
  validate_slices(grid_only);
  const ChunkLayout layout(set.grid);
  const std::size_t n = set.grid.cells();
  AmpSlices out;
  out.grid = set.grid;
  out.channels = set.channels;
  for (std::size_t s = 0; s < set.values.size(); ++s) {
    const std::vector<double>& v = set.values[s];
    if (v.size() != std::size_t(set.channels) * n)
      throw ConfigError("amplitude fit: slice " + std::to_string(s) + " does not hold channels x cells values");
    std::vector<float> w(std::size_t(kMaxChannels) * layout.stride, 0.0f);
    for (int c = 0; c < set.channels; ++c)
      for (std::size_t i = 0; i < n; ++i) {
        const double x = v[std::size_t(c) * n + i];
        if (!std::isfinite(x)) throw InputError("amplitude fit: slice " + std::to_string(s) + " holds a non-finite value");
        w[std::size_t(c) * layout.stride + i] = static_cast<float>(x);
      }
    out.w.push_back(std::move(w));
  }
  return out;
}

std::vector<AmplitudeSums> EmEngine::amplitude_sums(const AmpSlices& slices, const std::vector<AmplitudeQuery>& queries) {
  const SliceGrid& grid = slices.grid;
  const ChunkLayout layout(grid);
  const std::size_t n_cells = layout.cells, n_chunks = layout.chunks, stride = layout.stride;
  const double area = axis_step(grid.theta) * layout.dphi;
  const int C = slices.channels;
  for (const auto& q : queries) {
    if (q.slice >= slices.w.size())
      throw ConfigError("amplitude query: slice " + std::to_string(q.slice) + " out of range");
    if (q.gmm.k() < 1 || q.gmm.k() > kEmMaxK)
      throw ConfigError("amplitude query: K = " + std::to_string(q.gmm.k()) + " outside 1.." + std::to_string(kEmMaxK));
    if (q.amp.size() != std::size_t(C * q.gmm.k()) || q.delta.size() != std::size_t(C))
      throw ConfigError("amplitude query: amp must hold channels x K values and delta one per channel");
  }
  std::vector<AmplitudeSums> out(queries.size());
  std::map<int, std::vector<std::size_t>> groups;
  for (std::size_t i = 0; i < queries.size(); ++i) groups[k_bucket(queries[i].gmm.k())].push_back(i);
  // The basis (K_MAX rows) and the weights (kMaxChannels rows) of each problem stay on the device.
  const auto batches = bucket_batches(groups, stride, kMaxChannels, batch_budget_);

  std::vector<cl::CommandQueue> queues;
  std::vector<std::size_t> queue_device;
  make_queues(queues, queue_device);

  auto run_batch = [&](std::size_t worker, std::size_t bi) {
    const int K = batches[bi].first;
    const std::vector<std::size_t>& items = batches[bi].second;
    const std::size_t d = queue_device[worker];
    const Device& dev = devices_[d];
    const bool fp64 = uses_fp64(d);
    const KernelShape shape = shape_for(dev.info(), gpu_layout_);
    const std::size_t P = items.size(), real_size = fp64 ? 8 : 4, nconst = 6 * static_cast<std::size_t>(K);
    const std::size_t row = static_cast<std::size_t>(K) + 1, per_problem = static_cast<std::size_t>(K) * kMaxChannels * row;

    std::map<std::size_t, int> local_slice;
    std::vector<int> prob_slice(P), prob_k(P), images(P * K, 0), sub(P * K, 0);
    const double dth = axis_step(grid.theta);
    std::vector<float> cparams(P * nconst, 0.0f), amps(P * kMaxChannels * K, 0.0f), deltas(P * kMaxChannels, 0.0f);
    for (std::size_t i = 0; i < P; ++i) {
      const AmplitudeQuery& q = queries[items[i]];
      auto it = local_slice.find(q.slice);
      if (it == local_slice.end()) it = local_slice.emplace(q.slice, static_cast<int>(local_slice.size())).first;
      prob_slice[i] = it->second;
      const int k = prob_k[i] = q.gmm.k();
      float* cp = &cparams[i * nconst];
      for (int j = 0; j < k; ++j) {  // em_l1's constants, the normalization with the cell area and no weight
        const double a = q.gmm.cov[3 * j], b = q.gmm.cov[3 * j + 1], c = q.gmm.cov[3 * j + 2];
        component_constants(q.gmm, j, K, std::log2(area), cp);
        images[i * K + j] = l1_images(c);
        sub[i * K + j] = sub_cell(a, b, c, dth, layout.dphi) ? 1 : 0;
        for (int ch = 0; ch < C; ++ch) amps[(i * kMaxChannels + ch) * K + j] = static_cast<float>(q.amp[ch * k + j]);
      }
      for (int ch = 0; ch < C; ++ch) deltas[i * kMaxChannels + ch] = static_cast<float>(q.delta[ch]);
    }
    std::vector<float> channels(local_slice.size() * kMaxChannels * stride, 0.0f);
    for (const auto& [slice, local] : local_slice)
      std::copy(slices.w[slice].begin(), slices.w[slice].end(),
                channels.begin() + static_cast<std::ptrdiff_t>(local) * kMaxChannels * stride);
    std::vector<unsigned char> l1_parts(P * n_chunks * kMaxChannels * real_size), sums(P * per_problem * real_size);
    try {
      cl::Program program = build_program(dev, "em", em_program_options(K, shape, fp64));
      const cl::Context& ctx = dev.context();
      const cl::CommandQueue& queue = queues[worker];
      cl::Buffer b_channels(ctx, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, channels.size() * 4, channels.data());
      cl::Buffer b_slice(ctx, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, P * sizeof(int), prob_slice.data());
      cl::Buffer b_k(ctx, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, P * sizeof(int), prob_k.data());
      cl::Buffer b_const(ctx, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, cparams.size() * 4, cparams.data());
      cl::Buffer b_images(ctx, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, images.size() * sizeof(int), images.data());
      cl::Buffer b_sub(ctx, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, sub.size() * sizeof(int), sub.data());
      cl::Buffer b_amps(ctx, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, amps.size() * 4, amps.data());
      cl::Buffer b_deltas(ctx, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, deltas.size() * 4, deltas.data());
      cl::Buffer b_basis(ctx, CL_MEM_READ_WRITE, P * static_cast<std::size_t>(K) * stride * 4);
      cl::Buffer b_dw(ctx, CL_MEM_READ_WRITE, P * kMaxChannels * stride * 4);
      cl::Buffer b_l1(ctx, CL_MEM_WRITE_ONLY, l1_parts.size());
      cl::Buffer b_sums(ctx, CL_MEM_WRITE_ONLY, sums.size());
      cl::Kernel basis(program, "amp_basis"), normal(program, "amp_sums");
      set_grid_args(basis, layout, grid);
      basis.setArg(7, b_channels);
      basis.setArg(8, b_slice);
      basis.setArg(9, b_k);
      basis.setArg(10, b_const);
      basis.setArg(11, b_images);
      basis.setArg(12, b_sub);
      basis.setArg(13, static_cast<cl_uint>(n_cells));
      basis.setArg(14, static_cast<cl_int>(C));
      basis.setArg(15, b_amps);
      basis.setArg(16, b_deltas);
      basis.setArg(17, b_basis);
      basis.setArg(18, b_dw);
      basis.setArg(19, b_l1);
      normal.setArg(0, static_cast<cl_uint>(stride));
      normal.setArg(1, static_cast<cl_uint>(n_chunks));
      normal.setArg(2, b_channels);
      normal.setArg(3, b_slice);
      normal.setArg(4, b_k);
      normal.setArg(5, static_cast<cl_int>(C));
      normal.setArg(6, b_basis);
      normal.setArg(7, b_dw);
      normal.setArg(8, b_sums);
      const std::size_t wg = static_cast<std::size_t>(shape.wg);
      launch(queue, basis, "amp_basis", cl::NDRange(n_chunks * wg, P), cl::NDRange(wg, 1));
      launch(queue, normal, "amp_sums", cl::NDRange(wg, P, static_cast<std::size_t>(K)), cl::NDRange(wg, 1, 1));
      queue.enqueueReadBuffer(b_l1, CL_TRUE, 0, l1_parts.size(), l1_parts.data());
      queue.enqueueReadBuffer(b_sums, CL_TRUE, 0, sums.size(), sums.data());
    } catch (const cl::Error& e) {
      throw_device_error(e, "amplitude sums on " + dev.info().label());
    }
    for (std::size_t i = 0; i < P; ++i) {
      AmplitudeSums& v = out[items[i]];
      const int k = prob_k[i];
      v.gram.assign(std::size_t(C * k * k), 0.0);
      v.rhs.assign(std::size_t(C * k), 0.0);
      v.l1.assign(std::size_t(C), 0.0);
      for (std::size_t g = 0; g < n_chunks; ++g)
        for (int ch = 0; ch < C; ++ch) v.l1[ch] += unpack(l1_parts, (i * n_chunks + g) * kMaxChannels + ch, fp64);
      for (int j = 0; j < k; ++j)
        for (int ch = 0; ch < C; ++ch) {
          const std::size_t base = i * per_problem + (static_cast<std::size_t>(j) * kMaxChannels + ch) * row;
          v.rhs[ch * k + j] = unpack(sums, base + K, fp64);
          for (int a = 0; a <= j; ++a)
            v.gram[(ch * k + j) * k + a] = v.gram[(ch * k + a) * k + j] = unpack(sums, base + a, fp64);
        }
    }
  };
  run_on_workers(batches.size(), queues.size(), run_batch);
  return out;
}

}  // namespace bsdfmix
