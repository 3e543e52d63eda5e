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

std::vector<AmplitudeSums> EmEngine::amplitude_sums(const AmpSlices& slices, const std::vector<AmplitudeQuery>& queries) {
  if (!calibrated_) calibrate();
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
  for (const auto& [bucket, list] : groups) check_problem_fits(stride, bucket, kMaxChannels, device_limit());
  const auto batches = bucket_batches(groups, stride, kMaxChannels, budget());
  std::vector<double> cost;
  for (const auto& [K, items] : batches) cost.push_back(static_cast<double>(items.size()) * stride * (K + kMaxChannels));

  auto run_batch = [&](const BatchRun& run) {
    const int K = batches[run.batch].first;
    const std::vector<std::size_t>& items = batches[run.batch].second;
    const std::size_t d = run.device;
    const Device& dev = devices_[d];
    const bool fp64 = uses_fp64(d);
    const KernelShape shape = this->shape(d);
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
    const bool won = run_on_device(run, dev, "amplitude sums", [&] {
      cl::Program program = build_program(dev, "amplitudes", em_program_options(K, shape, fp64));
      const cl::CommandQueue& queue = *run.queue;
      cl::Buffer b_channels = upload(dev, "channels", channels), b_slice = upload(dev, "prob_slice", prob_slice),
                 b_k = upload(dev, "prob_k", prob_k);
      cl::Buffer b_basis = device_buffer(dev, "basis", P * static_cast<std::size_t>(K) * stride * 4, CL_MEM_READ_WRITE);
      cl::Buffer b_dw = device_buffer(dev, "dw", P * kMaxChannels * stride * 4, CL_MEM_READ_WRITE);
      cl::Buffer b_l1 = device_buffer(dev, "l1 partials", l1_parts.size(), CL_MEM_WRITE_ONLY);
      cl::Buffer b_sums = device_buffer(dev, "sums", sums.size(), CL_MEM_WRITE_ONLY);
      Routine basis(program, "amp_basis"), normal(program, "amp_sums");
      set_grid_args(basis, layout, grid);
      basis.set("channels", b_channels).set("prob_slice", b_slice).set("prob_k", b_k)
          .set("cparams", upload(dev, "cparams", cparams))
          .set("prob_images", upload(dev, "prob_images", images))
          .set("prob_sub", upload(dev, "prob_sub", sub))
          .set("n_cells", static_cast<cl_uint>(n_cells))
          .set("n_channels", static_cast<cl_int>(C))
          .set("amps", upload(dev, "amps", amps))
          .set("deltas", upload(dev, "deltas", deltas))
          .set("basis", b_basis).set("dw", b_dw).set("partials", b_l1);
      normal.set("slice_stride", static_cast<cl_uint>(stride)).set("n_chunks", static_cast<cl_uint>(n_chunks))
          .set("channels", b_channels).set("prob_slice", b_slice).set("prob_k", b_k)
          .set("n_channels", static_cast<cl_int>(C)).set("basis", b_basis).set("dw", b_dw).set("partials", b_sums);
      const std::size_t wg = static_cast<std::size_t>(shape.wg);
      basis.run(queue, cl::NDRange(n_chunks * wg, P), cl::NDRange(wg, 1));
      normal.run(queue, cl::NDRange(wg, P, static_cast<std::size_t>(K)), cl::NDRange(wg, 1, 1));
      download(queue, b_l1, l1_parts, true);
      download(queue, b_sums, sums, true);
    });
    if (!won) return;  // another device finished this batch first
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
  pool_->run("amplitudes", cost, run_batch);
  return out;
}

}  // namespace bsdfmix
