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
  }
  std::vector<L1Value> out(queries.size());
  // Batches: queries of one K bucket, up to the budget.
  std::map<int, std::vector<std::size_t>> groups;
  for (std::size_t i = 0; i < queries.size(); ++i) {
    out[i].stats.assign(6 * static_cast<std::size_t>(queries[i].gmm.k()), 0.0);
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
    const std::size_t nstat = 6 * static_cast<std::size_t>(K) + 1, nconst = 6 * static_cast<std::size_t>(K);

    std::map<std::size_t, int> local_slice;
    std::vector<int> prob_slice(P), prob_k(P), images(P * K, 0);
    std::vector<float> cparams(P * nconst, 0.0f);
    for (std::size_t i = 0; i < P; ++i) {
      const L1Query& q = queries[items[i]];
      auto it = local_slice.find(q.slice);
      if (it == local_slice.end()) it = local_slice.emplace(q.slice, static_cast<int>(local_slice.size())).first;
      prob_slice[i] = it->second;
      prob_k[i] = q.gmm.k();
      // The E-step constants of kernels/em.cl component_constants, in double then float.
      for (int j = 0; j < q.gmm.k(); ++j) {
        component_constants(q.gmm, j, K, std::log2(q.gmm.weight[j]), &cparams[i * nconst]);
        images[i * K + j] = l1_images(q.gmm.cov[3 * j + 2]);
      }
    }
    std::vector<float> weights(local_slice.size() * stride, 0.0f);
    for (const auto& [slice, local] : local_slice)
      std::copy(slices.w[slice].begin(), slices.w[slice].end(), weights.begin() + static_cast<std::ptrdiff_t>(local) * stride);
    std::vector<unsigned char> partials(P * n_chunks * nstat * real_size);
    try {
      cl::Program program = build_program(dev, "em", em_program_options(K, shape, fp64));
      const cl::Context& ctx = dev.context();
      const cl::CommandQueue& queue = queues[worker];
      cl::Buffer b_weights(ctx, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, weights.size() * 4, weights.data());
      cl::Buffer b_slice(ctx, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, P * sizeof(int), prob_slice.data());
      cl::Buffer b_k(ctx, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, P * sizeof(int), prob_k.data());
      cl::Buffer b_const(ctx, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, cparams.size() * 4, cparams.data());
      cl::Buffer b_images(ctx, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, images.size() * sizeof(int), images.data());
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
      kern.setArg(15, static_cast<float>(objective.kl));
      kern.setArg(16, b_partials);
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
        v.objective += unpack(partials, base + 6 * K, fp64);
        for (int q = 0; q < 6; ++q)
          for (int j = 0; j < k; ++j) v.stats[q * k + j] += unpack(partials, base + q * K + j, fp64);
      }
    }
  };
  run_on_workers(batches.size(), queues.size(), run_batch);
  return out;
}

}  // namespace bsdfmix
