// The amplitude fit's sums on the devices: kernels/amplitudes.cl amp_basis and amp_sums, batched by K bucket.
#include <algorithm>
#include <cmath>
#include <map>

#include "core/error.hpp"
#include "device/program.hpp"
#include "fit/em.hpp"
#include "fit/em_internal.hpp"

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

namespace {

void check_queries(const EmEngine::AmpSlices& slices, const std::vector<AmplitudeQuery>& queries) {
  const int C = slices.channels;
  for (const auto& q : queries) {
    check_query("amplitude query", q.slice, slices.w.size(), q.gmm.k());
    if (q.amp.size() != std::size_t(C * q.gmm.k()) || q.delta.size() != std::size_t(C))
      throw ConfigError("amplitude query: amp must hold channels x K values and delta one per channel");
  }
}

// The inputs of amp_basis for one batch of queries.
struct AmpBatch {
  BatchSlices slices;
  std::vector<int> prob_k, images, sub;
  std::vector<float> cparams, amps, deltas, channels;

  AmpBatch(const BatchWork& w, const EmEngine::AmpSlices& in, const std::vector<AmplitudeQuery>& queries,
           const ChunkLayout& layout, double area)
      : slices(w.size(), [&](std::size_t i) { return queries[w.batch.items[i]].slice; }) {
    const std::size_t P = w.size(), K = static_cast<std::size_t>(w.bucket()), nconst = 6 * K;
    const int C = in.channels;
    const double dth = axis_step(in.grid.theta);
    prob_k.resize(P);
    images.assign(P * K, 0);
    sub.assign(P * K, 0);
    cparams.assign(P * nconst, 0.0f);
    amps.assign(P * kMaxChannels * K, 0.0f);
    deltas.assign(P * kMaxChannels, 0.0f);
    for (std::size_t i = 0; i < P; ++i) {
      const AmplitudeQuery& q = queries[w.batch.items[i]];
      const int k = prob_k[i] = q.gmm.k();
      float* cp = &cparams[i * nconst];
      for (int j = 0; j < k; ++j) {  // em_l1's constants, the normalization with the cell area and no weight
        const double a = q.gmm.cov[3 * j], b = q.gmm.cov[3 * j + 1], c = q.gmm.cov[3 * j + 2];
        component_constants(q.gmm, j, static_cast<int>(K), std::log2(area), cp);
        images[i * K + j] = l1_images(c);
        sub[i * K + j] = sub_cell(a, b, c, dth, layout.dphi) ? 1 : 0;
        for (int ch = 0; ch < C; ++ch) amps[(i * kMaxChannels + ch) * K + j] = static_cast<float>(q.amp[ch * k + j]);
      }
      for (int ch = 0; ch < C; ++ch) deltas[i * kMaxChannels + ch] = static_cast<float>(q.delta[ch]);
    }
    channels.assign(slices.count() * kMaxChannels * layout.stride, 0.0f);
    for (const auto& [slice, local] : slices.of_slice)
      std::copy(in.w[slice].begin(), in.w[slice].end(),
                channels.begin() + static_cast<std::ptrdiff_t>(local) * kMaxChannels * layout.stride);
  }
};

// The sums of problem i of a batch from the downloaded partials.
void read_sums(AmplitudeSums& v, std::size_t i, int k, int K, int C, std::size_t n_chunks,
               const std::vector<unsigned char>& l1_parts, const std::vector<unsigned char>& sums, bool fp64) {
  const std::size_t row = static_cast<std::size_t>(K) + 1, per_problem = static_cast<std::size_t>(K) * kMaxChannels * row;
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

}  // namespace

std::vector<AmplitudeSums> EmEngine::amplitude_sums(const AmpSlices& slices, const std::vector<AmplitudeQuery>& queries) {
  if (!calibrated_) calibrate();
  const SliceGrid& grid = slices.grid;
  const ChunkLayout layout(grid);
  const std::size_t n_chunks = layout.chunks, stride = layout.stride;
  const double area = axis_step(grid.theta) * layout.dphi;
  const int C = slices.channels;
  check_queries(slices, queries);
  std::vector<AmplitudeSums> out(queries.size());
  std::map<int, std::vector<std::size_t>> groups;
  for (std::size_t i = 0; i < queries.size(); ++i) groups[k_bucket(queries[i].gmm.k())].push_back(i);
  // The basis (K_MAX rows) and the weights (kMaxChannels rows) of each problem stay on the device.
  const auto batches = plan_batches({groups.begin(), groups.end()}, stride, kMaxChannels, device_limit(), budget());
  std::vector<double> cost;
  for (const auto& b : batches) cost.push_back(static_cast<double>(b.items.size()) * stride * (b.bucket + kMaxChannels));

  run_batches("amplitudes", batches, cost, [&](const BatchWork& w) {
    const int K = w.bucket();
    const std::size_t P = w.size(), real_size = w.fp64 ? 8 : 4;
    const std::size_t per_problem = static_cast<std::size_t>(K) * kMaxChannels * (static_cast<std::size_t>(K) + 1);
    const AmpBatch in(w, slices, queries, layout, area);
    std::vector<unsigned char> l1_parts(P * n_chunks * kMaxChannels * real_size), sums(P * per_problem * real_size);
    const Device& dev = w.device;
    const bool won = run_on_device(w.run, dev, "amplitude sums", [&] {
      cl::Program program = build_program(dev, "amplitudes", em_program_options(K, w.shape, w.fp64, layout.map));
      const cl::CommandQueue& queue = *w.run.queue;
      cl::Buffer b_channels = upload(dev, "channels", in.channels), b_slice = upload(dev, "prob_slice", in.slices.local),
                 b_k = upload(dev, "prob_k", in.prob_k);
      cl::Buffer b_basis = device_buffer(dev, "basis", P * static_cast<std::size_t>(K) * stride * 4, CL_MEM_READ_WRITE);
      cl::Buffer b_dw = device_buffer(dev, "dw", P * kMaxChannels * stride * 4, CL_MEM_READ_WRITE);
      cl::Buffer b_l1 = device_buffer(dev, "l1 partials", l1_parts.size(), CL_MEM_WRITE_ONLY);
      cl::Buffer b_sums = device_buffer(dev, "sums", sums.size(), CL_MEM_WRITE_ONLY);
      Routine basis(program, "amp_basis"), normal(program, "amp_sums");
      set_grid_args(basis, layout, grid);
      basis.set("channels", b_channels).set("prob_slice", b_slice).set("prob_k", b_k)
          .set("cparams", upload(dev, "cparams", in.cparams))
          .set("prob_images", upload(dev, "prob_images", in.images))
          .set("prob_sub", upload(dev, "prob_sub", in.sub))
          .set("n_cells", static_cast<cl_uint>(layout.cells))
          .set("n_channels", static_cast<cl_int>(C))
          .set("amps", upload(dev, "amps", in.amps))
          .set("deltas", upload(dev, "deltas", in.deltas))
          .set("basis", b_basis).set("dw", b_dw).set("partials", b_l1);
      normal.set("slice_stride", static_cast<cl_uint>(stride)).set("n_chunks", static_cast<cl_uint>(n_chunks))
          .set("channels", b_channels).set("prob_slice", b_slice).set("prob_k", b_k)
          .set("n_channels", static_cast<cl_int>(C)).set("basis", b_basis).set("dw", b_dw).set("partials", b_sums);
      const std::size_t wg = static_cast<std::size_t>(w.shape.wg);
      basis.run(queue, cl::NDRange(n_chunks * wg, P), cl::NDRange(wg, 1));
      normal.run(queue, cl::NDRange(wg, P, static_cast<std::size_t>(K)), cl::NDRange(wg, 1, 1));
      download(queue, b_l1, l1_parts, true);
      download(queue, b_sums, sums, true);
    });
    if (!won) return;  // another device finished this batch first
    for (std::size_t i = 0; i < P; ++i)
      read_sums(out[w.batch.items[i]], i, in.prob_k[i], K, C, n_chunks, l1_parts, sums, w.fp64);
  });
  return out;
}

}  // namespace bsdfmix
