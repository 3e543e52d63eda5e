// The L1 refinement's evaluations on the devices: kernels/l1.cl em_l1, batched by K bucket.
#include <algorithm>
#include <cmath>
#include <map>

#include "core/error.hpp"
#include "device/program.hpp"
#include "fit/em.hpp"
#include "fit/em_internal.hpp"

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
  if (!calibrated_) calibrate();
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
  for (const auto& [bucket, list] : groups) check_problem_fits(stride, bucket, 0, device_limit());
  const auto batches = bucket_batches(groups, stride, 0, budget());
  std::vector<double> cost;
  for (const auto& [K, items] : batches) cost.push_back(static_cast<double>(items.size()) * stride * K);

  auto run_batch = [&](const BatchRun& run) {
    const int K = batches[run.batch].first;
    const std::vector<std::size_t>& items = batches[run.batch].second;
    const std::size_t d = run.device;
    const Device& dev = devices_[d];
    const bool fp64 = uses_fp64(d);
    const KernelShape shape = this->shape(d);
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
    const bool won = run_on_device(run, dev, "L1 evaluation", [&] {
      cl::Program program =
          build_program(dev, "l1", em_program_options(K, shape, fp64) + (colour ? " -DL1_CH=3" : ""));
      const cl::CommandQueue& queue = *run.queue;
      Routine kern(program, "em_l1");
      set_grid_args(kern, layout, grid);
      cl::Buffer b_partials = device_buffer(dev, "partials", partials.size(), CL_MEM_WRITE_ONLY);
      kern.set("weights", upload(dev, "weights", weights))
          .set("prob_slice", upload(dev, "prob_slice", prob_slice))
          .set("prob_k", upload(dev, "prob_k", prob_k))
          .set("cparams", upload(dev, "cparams", cparams))
          .set("prob_images", upload(dev, "prob_images", images))
          .set("n_cells", static_cast<cl_uint>(n_cells))
          .set("area", static_cast<float>(area))
          .set("eps", static_cast<float>(objective.eps))
          .set("prob_weights", upload(dev, "prob_weights", prob_weights))
          .set("channels", upload(dev, "channels", channels))
          .set("camp", upload(dev, "camp", camp))
          .set("partials", b_partials);
      kern.run(queue, cl::NDRange(n_chunks * static_cast<std::size_t>(shape.wg), P),
               cl::NDRange(static_cast<std::size_t>(shape.wg), 1));
      download(queue, b_partials, partials, true);
    });
    if (!won) return;  // another device finished this batch first
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
  pool_->run("l1", cost, run_batch);
  return out;
}

}  // namespace bsdfmix
