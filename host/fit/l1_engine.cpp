// The L1 refinement's evaluations on the devices: kernels/em.cl em_l1, batched by K bucket.
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

EmEngine::L1Slices EmEngine::l1_prepare(const SliceSet& set) {
  validate_slices(set);
  L1Slices out;
  out.grid = set.grid;
  out.w.resize(set.weights.size());
  for (std::size_t s = 0; s < set.weights.size(); ++s) {
    const PreparedSlice p = prepare_slice(set, s);
    out.w[s].assign(p.w.begin(), p.w.end());
  }
  if (!set.rgb.empty()) {
    if (set.rgb.size() != set.weights.size())
      throw InputError("L1 slices: " + std::to_string(set.rgb.size()) + " colour slices for " +
                       std::to_string(set.weights.size()));
    const ChunkLayout layout(set.grid);
    const std::size_t n = layout.cells;
    out.rgb.resize(set.rgb.size());
    for (std::size_t s = 0; s < set.rgb.size(); ++s) {
      out.rgb[s].assign(3 * layout.stride, 0.0f);
      const std::vector<double> ch = l1_channels(set, s);
      for (std::size_t c = 0; c < 3 && !ch.empty(); ++c)
        for (std::size_t i = 0; i < n; ++i) out.rgb[s][c * layout.stride + i] = static_cast<float>(ch[c * n + i]);
    }
  }
  return out;
}

std::vector<L1Value> EmEngine::l1_values(const L1Slices& slices, const std::vector<L1Query>& queries,
                                         const L1Objective& objective) {
  const SliceGrid& grid = slices.grid;
  const ChunkLayout layout(grid);
  const std::size_t n_cells = layout.cells, n_chunks = layout.chunks, stride = layout.stride;
  const double area = axis_step(grid.theta) * layout.dphi;

  for (const auto& q : queries) {
    if (q.slice >= slices.w.size())
      throw ConfigError("L1 query: slice " + std::to_string(q.slice) + " out of range");
    if (q.gmm.k() < 1 || q.gmm.k() > kEmMaxK)
      throw ConfigError("L1 query: K = " + std::to_string(q.gmm.k()) + " outside 1.." + std::to_string(kEmMaxK));
    if (!q.rgb_amp.empty() && q.rgb_amp.size() != 3 * static_cast<std::size_t>(q.gmm.k()))
      throw ConfigError("L1 query: " + std::to_string(q.rgb_amp.size()) + " channel amplitudes, expected " +
                        std::to_string(3 * q.gmm.k()));
    if (!q.rgb_amp.empty() && slices.rgb.empty())
      throw ConfigError("L1 query: channel amplitudes, but the slices have no rgb");
  }
  std::vector<L1Value> out(queries.size());
  // Batches: queries of one K bucket, up to the budget.
  std::map<int, std::vector<std::size_t>> groups;
  for (std::size_t i = 0; i < queries.size(); ++i) {
    out[i].stats.assign((queries[i].rgb_amp.empty() ? 6 : 9) * static_cast<std::size_t>(queries[i].gmm.k()), 0.0);
    if (slices.w[queries[i].slice].empty()) continue;  // a zero slice: objective 0
    groups[k_bucket(queries[i].gmm.k())].push_back(i);
  }
  const auto batches = bucket_batches(groups, stride, 0, batch_budget_);

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
    const std::size_t P = items.size(), real_size = fp64 ? 8 : 4;
    // The channels' variant of the kernel when some query of the batch has them.
    const bool colour = std::any_of(items.begin(), items.end(), [&](std::size_t i) { return !queries[i].rgb_amp.empty(); });
    const std::size_t nq = colour ? 9 : 6;
    const std::size_t nstat = nq * static_cast<std::size_t>(K) + 1, nconst = 6 * static_cast<std::size_t>(K);

    std::map<std::size_t, int> local_slice;
    std::vector<int> prob_slice(P), prob_k(P), images(P * K, 0);
    std::vector<float> cparams(P * nconst, 0.0f), camp(colour ? P * 3 * K : 1, 0.0f), prob_weights(2 * P);
    for (std::size_t i = 0; i < P; ++i) {
      const L1Query& q = queries[items[i]];
      auto it = local_slice.find(q.slice);
      if (it == local_slice.end()) it = local_slice.emplace(q.slice, static_cast<int>(local_slice.size())).first;
      prob_slice[i] = it->second;
      prob_k[i] = q.gmm.k();
      const L1Weights w = l1_weights(objective, !q.rgb_amp.empty());
      prob_weights[2 * i] = static_cast<float>(w.kl);
      prob_weights[2 * i + 1] = static_cast<float>(w.rgb);
      // The E-step constants of kernels/em.cl component_constants, in double then float.
      for (int j = 0; j < q.gmm.k(); ++j) {
        component_constants(q.gmm, j, K, std::log2(q.gmm.weight[j]), &cparams[i * nconst]);
        images[i * K + j] = l1_images(q.gmm.cov[3 * j + 2]);
        if (!q.rgb_amp.empty())  // the kernel weighs pi_j N_j: each channel's amplitude over pi_j
          for (int c = 0; c < 3; ++c)
            camp[(i * 3 + c) * K + j] = static_cast<float>(q.rgb_amp[c * q.gmm.k() + j] / q.gmm.weight[j]);
      }
    }
    std::vector<float> weights(local_slice.size() * stride, 0.0f);
    for (const auto& [slice, local] : local_slice)
      std::copy(slices.w[slice].begin(), slices.w[slice].end(), weights.begin() + static_cast<std::ptrdiff_t>(local) * stride);
    std::vector<float> channels(colour ? local_slice.size() * 3 * stride : 1, 0.0f);
    if (colour)
      for (const auto& [slice, local] : local_slice)
        std::copy(slices.rgb[slice].begin(), slices.rgb[slice].end(),
                  channels.begin() + static_cast<std::ptrdiff_t>(local) * 3 * stride);
    std::vector<unsigned char> partials(P * n_chunks * nstat * real_size);
    try {
      cl::Program program =
          build_program(dev, "em", em_program_options(K, shape, fp64) + (colour ? " -DL1_CH=3" : ""));
      const cl::Context& ctx = dev.context();
      const cl::CommandQueue& queue = queues[worker];
      cl::Buffer b_weights(ctx, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, weights.size() * 4, weights.data());
      cl::Buffer b_slice(ctx, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, P * sizeof(int), prob_slice.data());
      cl::Buffer b_k(ctx, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, P * sizeof(int), prob_k.data());
      cl::Buffer b_const(ctx, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, cparams.size() * 4, cparams.data());
      cl::Buffer b_images(ctx, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, images.size() * sizeof(int), images.data());
      cl::Buffer b_channels(ctx, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, channels.size() * 4, channels.data());
      cl::Buffer b_camp(ctx, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, camp.size() * 4, camp.data());
      cl::Buffer b_weights_p(ctx, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, prob_weights.size() * 4, prob_weights.data());
      cl::Buffer b_partials(ctx, CL_MEM_WRITE_ONLY, partials.size());
      cl::Kernel kern(program, "em_l1");
      set_grid_args(kern, layout, grid);
      kern.setArg(7, b_weights);
      kern.setArg(8, b_slice);
      kern.setArg(9, b_k);
      kern.setArg(10, b_const);
      kern.setArg(11, b_images);
      kern.setArg(12, static_cast<cl_uint>(n_cells));
      kern.setArg(13, static_cast<float>(area));
      kern.setArg(14, static_cast<float>(objective.eps));
      kern.setArg(15, b_weights_p);
      kern.setArg(16, b_channels);
      kern.setArg(17, b_camp);
      kern.setArg(18, b_partials);
      launch(queue, kern, "em_l1", cl::NDRange(n_chunks * static_cast<std::size_t>(shape.wg), P),
             cl::NDRange(static_cast<std::size_t>(shape.wg), 1));
      queue.enqueueReadBuffer(b_partials, CL_TRUE, 0, partials.size(), partials.data());
    } catch (const cl::Error& e) {
      throw_device_error(e, "L1 evaluation on " + dev.info().label());
    }
    for (std::size_t i = 0; i < P; ++i) {
      L1Value& v = out[items[i]];
      const int k = prob_k[i];
      for (std::size_t g = 0; g < n_chunks; ++g) {
        const std::size_t base = (i * n_chunks + g) * nstat;
        v.objective += unpack(partials, base + nq * K, fp64);
        for (int q = 0; q < static_cast<int>(v.stats.size()) / k; ++q)
          for (int j = 0; j < k; ++j) v.stats[q * k + j] += unpack(partials, base + q * K + j, fp64);
      }
    }
  };
  run_on_workers(batches.size(), queues.size(), run_batch);
  return out;
}

}  // namespace bsdfmix
