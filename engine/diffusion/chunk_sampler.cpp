// One chunk's DDIM sampling with guidance and outpainting; see chunk_sampler.h.
#include "diffusion/chunk_sampler.h"

#include "diffusion/counter_noise.h"
#include "gpu/context.h"
#include "nn/sampler_step.h"

#include <algorithm>
#include <chrono>
#include <optional>
#include <stdexcept>
#include <string>

namespace icube::diffusion {

namespace {

using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

// x[c][v] = a * known[c][v] + b * z[c][v] where mask[v].
void overwrite(std::vector<float>& x, const KnownLatents& k, size_t spatial, float a, float b, const std::vector<float>* z) {
  for (size_t i = 0; i < x.size(); ++i)
    if (k.mask[i % spatial]) x[i] = z ? a * k.values[i] + b * (*z)[i] : k.values[i];
}

}  // namespace

bool KnownLatents::any() const { return std::any_of(mask.begin(), mask.end(), [](uint32_t m) { return m != 0; }); }

ChunkSample sample_chunk(Denoiser& denoiser, int latent_channels, const nn::CpuTensor& cond, const KnownLatents* known,
                         uint32_t chunk_index, const SamplerOptions& o, gpu::Context* ctx,
                         const std::function<void(size_t, size_t)>& progress) {
  if (cond.shape.size() != 4 || cond.shape[0] != 8)
    throw std::invalid_argument("sample_chunk: the condition volume is not [8, X, Y, Z]");
  if (latent_channels < 1) throw std::invalid_argument("sample_chunk: " + std::to_string(latent_channels) + " latent channels");
  const int64_t C = latent_channels, X = cond.shape[1], Y = cond.shape[2], Z = cond.shape[3];
  const size_t spatial = static_cast<size_t>(X * Y * Z), n = static_cast<size_t>(C) * spatial;
  const bool outpaint = known && known->any();
  if (outpaint && (known->mask.size() != spatial || known->values.size() != n))
    throw std::invalid_argument("sample_chunk: known latents of " + std::to_string(known->values.size()) + " values and " +
                                std::to_string(known->mask.size()) + " mask cells for a " + std::to_string(C) + " x " +
                                std::to_string(spatial) + " latent");
  const DdimSchedule sched(o.ddim);
  const bool cfg = o.cfg_scale != 1.0f;
  const int64_t B = cfg ? 2 : 1;

  ChunkSample out;
  std::vector<float> x(n), z(n);
  normal_noise({o.seed, chunk_index, 0, NoisePurpose::InitialLatent}, 0, x.data(), n);

  // The step and the overwrite on the GPU: x, the predictions and the noise uploaded, the result read
  // back (the denoiser takes and returns host tensors; the copies are small beside a UNet call). Without
  // a context the CPU references run.
  std::optional<kernels::nn::SamplerStep> gpu_step;
  std::optional<gpu::Buffer> xb, cb, ub, zb, yb, known_b, mask_b;
  if (ctx) {
    gpu_step.emplace(*ctx);
    const uint64_t bytes = n * 4;
    for (auto* b : {&xb, &cb, &ub, &zb, &yb}) b->emplace(*ctx, bytes, gpu::MemoryUsage::DeviceLocal, "sampler latent");
    if (outpaint) {
      known_b.emplace(gpu::upload_vector(*ctx, known->values, "sampler known latents"));
      mask_b.emplace(gpu::upload_vector(*ctx, known->mask, "sampler known mask"));
    }
  }
  // x's known cells = a known + b z (z: the level's fresh noise), or the clean known latents without z.
  auto apply_known = [&](float a, float b, const std::vector<float>* noise) {
    if (!gpu_step) return overwrite(x, *known, spatial, a, b, noise);
    gpu::upload(*ctx, *xb, x.data(), n * 4);
    // Without noise: b = 0 and z = the known latents themselves (finite), so the result is `known` exactly.
    if (noise) gpu::upload(*ctx, *zb, noise->data(), n * 4);
    ctx->submit_and_wait([&](gpu::CommandList& cmd) {
      gpu_step->overwrite_known(cmd, static_cast<uint32_t>(C), spatial, noise ? a : 1.0f, noise ? b : 0.0f, *known_b, *mask_b,
                                noise ? *zb : *known_b, *xb);
    });
    x = gpu::download_vector<float>(*ctx, *xb, n);
  };

  nn::CpuTensor input({B, C + 8, X, Y, Z});
  for (int64_t b = 0; b < B; ++b)
    for (int64_t c = 0; c < 8; ++c) {
      if (b == 1 && c >= kUncondFirstChannel) continue;  // unconditional: map and boxes zeroed
      std::copy_n(cond.data.begin() + static_cast<int64_t>(static_cast<size_t>(c) * spatial), spatial,
                  input.data.begin() + static_cast<int64_t>((static_cast<size_t>(b * (C + 8) + C + c)) * spatial));
    }
  if (progress) progress(0, sched.size());
  for (size_t i = 0; i < sched.size(); ++i) {
    const DdimStep st = sched.step(i);
    StepTiming timing;
    timing.t = st.t;
    if (outpaint) {
      float a = 0, s = 0;
      sched.noise_level(st.t, &a, &s);
      normal_noise({o.seed, chunk_index, static_cast<uint32_t>(st.t), NoisePurpose::KnownLatent}, 0, z.data(), n);
      apply_known(a, s, &z);
    }
    for (int64_t b = 0; b < B; ++b)
      std::copy(x.begin(), x.end(), input.data.begin() + static_cast<int64_t>(static_cast<size_t>(b * (C + 8)) * spatial));
    Clock::time_point t0 = Clock::now();
    const nn::CpuTensor v = denoiser.predict(input, st.t);
    timing.denoise_ms = ms_since(t0);
    if (v.shape != std::vector<int64_t>{B, C, X, Y, Z})
      throw std::invalid_argument("sample_chunk: the denoiser returned a tensor of another shape than [B, C, X, Y, Z]");
    t0 = Clock::now();
    const bool noise = st.sigma != 0.0f;
    if (noise) normal_noise({o.seed, chunk_index, static_cast<uint32_t>(st.t), NoisePurpose::StepNoise}, 0, z.data(), n);
    if (gpu_step) {
      gpu::upload(*ctx, *xb, x.data(), n * 4);
      gpu::upload(*ctx, *cb, v.data.data(), n * 4);
      if (cfg) gpu::upload(*ctx, *ub, v.data.data() + n, n * 4);
      if (noise) gpu::upload(*ctx, *zb, z.data(), n * 4);
      const kernels::nn::DdimStepCoefficients c{st.sqrt_alpha, st.sqrt_beta, st.sqrt_alpha_prev, st.direction, st.sigma};
      ctx->submit_and_wait([&](gpu::CommandList& cmd) {
        gpu_step->step(cmd, c, n, *xb, *cb, cfg ? &*ub : nullptr, o.cfg_scale, noise ? &*zb : nullptr, *yb);
      });
      x = gpu::download_vector<float>(*ctx, *yb, n);
    } else {
      std::vector<float> guided;
      const float* vp = v.data.data();
      if (cfg) {
        guided.resize(n);
        cfg_combine_cpu(v.data.data(), v.data.data() + n, o.cfg_scale, guided.data(), n);
        vp = guided.data();
      }
      std::vector<float> next(n);
      ddim_step_cpu(st, x.data(), vp, noise ? z.data() : nullptr, next.data(), n);
      x.swap(next);
    }
    timing.step_ms = ms_since(t0);
    out.steps.push_back(timing);
    if (progress) progress(i + 1, sched.size());
  }
  if (outpaint && o.final_overwrite) apply_known(1.0f, 0.0f, nullptr);
  out.latent = nn::CpuTensor({1, C, X, Y, Z}, std::move(x));
  return out;
}

}  // namespace icube::diffusion
