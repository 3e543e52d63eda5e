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

namespace {

void check_queries(const EmEngine::L1Slices& slices, const std::vector<L1Query>& queries) {
  for (const auto& q : queries) {
    check_query("L1 query", q.slice, slices.w.size(), q.gmm.k());
    if (!q.rgb_amp.empty() && q.rgb_amp.size() != 3 * static_cast<std::size_t>(q.gmm.k()))
      throw ConfigError("L1 query: " + std::to_string(q.rgb_amp.size()) + " channel amplitudes, expected " +
                        std::to_string(3 * q.gmm.k()));
    if (!q.rgb_amp.empty() && slices.rgb.empty())
      throw ConfigError("L1 query: channel amplitudes, but the slices have no rgb");
  }
}

// The inputs of em_l1 for one batch of queries.
struct L1Batch {
  bool colour = false;  // the channels' variant of the kernel: some query of the batch has them
  std::size_t nq = 6;   // sums per component
  BatchSlices slices;
  std::vector<int> prob_k, images;
  std::vector<float> cparams, camp, prob_weights, weights, channels;

  L1Batch(const BatchWork& w, const EmEngine::L1Slices& in, const std::vector<L1Query>& queries,
          const L1Objective& objective, std::size_t stride)
      : slices(w.size(), [&](std::size_t i) { return queries[w.batch.items[i]].slice; }) {
    const std::vector<std::size_t>& items = w.batch.items;
    const std::size_t P = w.size(), K = static_cast<std::size_t>(w.bucket()), nconst = 6 * K;
    colour = std::any_of(items.begin(), items.end(), [&](std::size_t i) { return !queries[i].rgb_amp.empty(); });
    nq = colour ? 9 : 6;
    prob_k.resize(P);
    images.assign(P * K, 0);
    cparams.assign(P * nconst, 0.0f);
    camp.assign(colour ? P * 3 * K : 1, 0.0f);
    prob_weights.resize(2 * P);
    for (std::size_t i = 0; i < P; ++i) {
      const L1Query& q = queries[items[i]];
      prob_k[i] = q.gmm.k();
      const L1Weights lw = l1_weights(objective, !q.rgb_amp.empty());
      prob_weights[2 * i] = static_cast<float>(lw.kl);
      prob_weights[2 * i + 1] = static_cast<float>(lw.rgb);
      // The E-step constants of kernels/em.cl component_constants, in double then float.
      for (int j = 0; j < q.gmm.k(); ++j) {
        component_constants(q.gmm, j, static_cast<int>(K), std::log2(q.gmm.weight[j]), &cparams[i * nconst]);
        images[i * K + j] = l1_images(q.gmm.cov[3 * j + 2]);
        if (!q.rgb_amp.empty())  // the kernel weighs pi_j N_j: each channel's amplitude over pi_j
          for (int c = 0; c < 3; ++c)
            camp[(i * 3 + c) * K + j] = static_cast<float>(q.rgb_amp[c * q.gmm.k() + j] / q.gmm.weight[j]);
      }
    }
    weights.assign(slices.count() * stride, 0.0f);
    for (const auto& [slice, local] : slices.of_slice)
      std::copy(in.w[slice].begin(), in.w[slice].end(), weights.begin() + static_cast<std::ptrdiff_t>(local) * stride);
    channels.assign(colour ? slices.count() * 3 * stride : 1, 0.0f);
    if (colour)
      for (const auto& [slice, local] : slices.of_slice)
        std::copy(in.rgb[slice].begin(), in.rgb[slice].end(),
                  channels.begin() + static_cast<std::ptrdiff_t>(local) * 3 * stride);
  }
};

}  // namespace

std::vector<L1Value> EmEngine::l1_values(const L1Slices& slices, const std::vector<L1Query>& queries,
                                         const L1Objective& objective) {
  if (!calibrated_) calibrate();
  const SliceGrid& grid = slices.grid;
  const ChunkLayout layout(grid);
  const std::size_t n_chunks = layout.chunks, stride = layout.stride;
  const double area = axis_step(grid.theta) * layout.dphi;
  check_queries(slices, queries);
  std::vector<L1Value> out(queries.size());
  // Batches: queries of one K bucket, up to the budget.
  std::map<int, std::vector<std::size_t>> groups;
  for (std::size_t i = 0; i < queries.size(); ++i) {
    out[i].stats.assign((queries[i].rgb_amp.empty() ? 6 : 9) * static_cast<std::size_t>(queries[i].gmm.k()), 0.0);
    if (slices.w[queries[i].slice].empty()) continue;  // a zero slice: objective 0
    groups[k_bucket(queries[i].gmm.k())].push_back(i);
  }
  const auto batches = plan_batches({groups.begin(), groups.end()}, stride, 0, device_limit(), budget());
  std::vector<double> cost;
  for (const auto& b : batches) cost.push_back(static_cast<double>(b.items.size()) * stride * b.bucket);

  run_batches("l1", batches, cost, [&](const BatchWork& w) {
    const int K = w.bucket();
    const std::size_t P = w.size(), real_size = w.fp64 ? 8 : 4;
    const L1Batch in(w, slices, queries, objective, stride);
    const std::size_t nstat = in.nq * static_cast<std::size_t>(K) + 1;
    std::vector<unsigned char> partials(P * n_chunks * nstat * real_size);
    const Device& dev = w.device;
    const bool won = run_on_device(w.run, dev, "L1 evaluation", [&] {
      cl::Program program =
          build_program(dev, "l1", em_program_options(K, w.shape, w.fp64, layout.map) + (in.colour ? " -DL1_CH=3" : ""));
      Routine kern(program, "em_l1");
      set_grid_args(kern, layout, grid);
      cl::Buffer b_partials = device_buffer(dev, "partials", partials.size(), CL_MEM_WRITE_ONLY);
      kern.set("weights", upload(dev, "weights", in.weights))
          .set("prob_slice", upload(dev, "prob_slice", in.slices.local))
          .set("prob_k", upload(dev, "prob_k", in.prob_k))
          .set("cparams", upload(dev, "cparams", in.cparams))
          .set("prob_images", upload(dev, "prob_images", in.images))
          .set("n_cells", static_cast<cl_uint>(layout.cells))
          .set("area", static_cast<float>(area))
          .set("eps", static_cast<float>(objective.eps))
          .set("prob_weights", upload(dev, "prob_weights", in.prob_weights))
          .set("channels", upload(dev, "channels", in.channels))
          .set("camp", upload(dev, "camp", in.camp))
          .set("partials", b_partials);
      kern.run(*w.run.queue, cl::NDRange(n_chunks * static_cast<std::size_t>(w.shape.wg), P),
               cl::NDRange(static_cast<std::size_t>(w.shape.wg), 1));
      download(*w.run.queue, b_partials, partials, true);
    });
    if (!won) return;  // another device finished this batch first
    for (std::size_t i = 0; i < P; ++i) {
      L1Value& v = out[w.batch.items[i]];
      const int k = in.prob_k[i];
      for (std::size_t g = 0; g < n_chunks; ++g) {
        const std::size_t base = (i * n_chunks + g) * nstat;
        v.objective += unpack(partials, base + in.nq * K, w.fp64);
        for (int q = 0; q < static_cast<int>(v.stats.size()) / k; ++q)
          for (int j = 0; j < k; ++j) v.stats[q * k + j] += unpack(partials, base + q * K + j, w.fp64);
      }
    }
  });
  return out;
}

}  // namespace bsdfmix
