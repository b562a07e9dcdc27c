// One chunk's DDIM sampling with guidance and outpainting; see chunk_sampler.h.
#include "diffusion/chunk_sampler.h"

#include "diffusion/counter_noise.h"
#include "diffusion/dpm_solver.h"
#include "gpu/commands.h"
#include "gpu/context.h"
#include "kernels/nn/ddim_step.h"
#include "kernels/nn/dpm_solver_step.h"
#include "kernels/nn/latent_overwrite.h"

#include <algorithm>
#include <chrono>
#include <optional>
#include <stdexcept>
#include <string>

namespace icube::diffusion {

namespace {

using Clock = std::chrono::steady_clock;

// Kernel or copy writes, then kernels or copies that read or overwrite them.
constexpr gpu::MemoryDependency kWritesBeforeNextSubmission{
    VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT,
    VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT | VK_ACCESS_2_TRANSFER_WRITE_BIT,
    VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT,
    VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_SAMPLED_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT |
        VK_ACCESS_2_TRANSFER_READ_BIT | VK_ACCESS_2_TRANSFER_WRITE_BIT};

double ms_since(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

// The sizes of one chunk's sampling.
struct ChunkDims {
  int64_t B = 1, C = 0, X = 0, Y = 0, Z = 0;
  size_t spatial = 0, n = 0;  // voxels, latent values (C * voxels)
  bool cfg = false, outpaint = false;
  std::vector<int64_t> input_shape() const { return {B, C + 8, X, Y, Z}; }
  std::vector<int64_t> prediction_shape() const { return {B, C, X, Y, Z}; }
};

// The denoiser's input with the condition channels filled and the latent slots zero: for each batch
// element the latent's C channels, then the 8 condition channels (map and boxes zeroed in the
// unconditional element).
nn::CpuTensor conditioned_batch(const ChunkDims& d, const nn::CpuTensor& cond) {
  nn::CpuTensor input(d.input_shape());
  for (int64_t b = 0; b < d.B; ++b)
    for (int64_t c = 0; c < 8; ++c) {
      if (b == 1 && c >= kUncondFirstChannel) continue;  // unconditional: map and boxes zeroed
      std::copy_n(cond.data.begin() + static_cast<int64_t>(static_cast<size_t>(c) * d.spatial), d.spatial,
                  input.data.begin() + static_cast<int64_t>((static_cast<size_t>(b * (d.C + 8) + d.C + c)) * d.spatial));
    }
  return input;
}

uint64_t transferred_since(const gpu::HostTransferBytes& before) {
  const gpu::HostTransferBytes now = gpu::host_transfer_bytes();
  return (now.to_device - before.to_device) + (now.to_host - before.to_host);
}

// The CPU references: the latent on the host, the denoiser's host form.
ChunkSample sample_on_host(Denoiser& denoiser, const ChunkDims& d, const nn::CpuTensor& cond, const KnownLatents* known,
                           uint32_t chunk_index, const SamplerOptions& o, const std::function<void(size_t, size_t)>& progress) {
  const DdimSchedule sched(schedule_options(o));
  const bool dpm = o.kind == SamplerKind::kDpmSolver2M;
  ChunkSample out;
  std::vector<float> x(d.n), z(d.n), x0_prev(dpm ? d.n : 0), x0(dpm ? d.n : 0);  // DPM: this and the previous x0
  normal_noise({o.seed, chunk_index, 0, NoisePurpose::InitialLatent}, 0, x.data(), d.n);
  nn::CpuTensor input = conditioned_batch(d, cond);
  if (progress) progress(0, sched.size());
  for (size_t i = 0; i < sched.size(); ++i) {
    const DdimStep st = sched.step(i);
    StepTiming timing;
    timing.t = st.t;
    if (d.outpaint) {
      float a = 0, s = 0;
      sched.noise_level(st.t, &a, &s);
      normal_noise({o.seed, chunk_index, static_cast<uint32_t>(st.t), NoisePurpose::KnownLatent}, 0, z.data(), d.n);
      nn::cpu::latent_overwrite(x, known->mask, known->values, a, s, &z);
    }
    for (int64_t b = 0; b < d.B; ++b)
      std::copy(x.begin(), x.end(), input.data.begin() + static_cast<int64_t>(static_cast<size_t>(b * (d.C + 8)) * d.spatial));
    Clock::time_point t0 = Clock::now();
    const nn::CpuTensor v = denoiser.predict(input, st.t);
    timing.denoise_ms = ms_since(t0);
    if (v.shape != d.prediction_shape())
      throw std::invalid_argument("sample_chunk: the denoiser returned a tensor of another shape than [B, C, X, Y, Z]");
    t0 = Clock::now();
    const bool noise = !dpm && st.sigma != 0.0f;
    if (noise) normal_noise({o.seed, chunk_index, static_cast<uint32_t>(st.t), NoisePurpose::StepNoise}, 0, z.data(), d.n);
    std::vector<float> guided;
    const float* vp = v.data.data();
    if (d.cfg) {
      guided.resize(d.n);
      nn::cpu::cfg_combine(v.data.data(), v.data.data() + d.n, o.cfg_scale, guided.data(), d.n);
      vp = guided.data();
    }
    std::vector<float> next(d.n);
    if (dpm) {
      const kernels::nn::DpmSolverStepCoefficients c = dpm_solver_coefficients(sched, i);
      nn::cpu::dpm_solver_step(c, x.data(), vp, c.second_order() ? x0_prev.data() : nullptr, next.data(), x0.data(), d.n);
      x0_prev.swap(x0);
    } else {
      nn::cpu::ddim_step(st.coefficients(), x.data(), vp, noise ? z.data() : nullptr, next.data(), d.n);
    }
    x.swap(next);
    timing.step_ms = ms_since(t0);
    out.steps.push_back(timing);
    if (progress) progress(i + 1, sched.size());
  }
  if (d.outpaint && o.final_overwrite) nn::cpu::latent_overwrite(x, known->mask, known->values, 1.0f, 0.0f, nullptr);
  out.latent = nn::CpuTensor({1, d.C, d.X, d.Y, d.Z}, std::move(x));
  return out;
}

// The latent on the device from the initial noise to the end; see chunk_sampler.h.
ChunkSample sample_on_device(Denoiser& denoiser, const ChunkDims& d, const nn::CpuTensor& cond, const KnownLatents* known,
                             uint32_t chunk_index, const SamplerOptions& o, gpu::Context& ctx,
                             const std::function<void(size_t, size_t)>& progress) {
  const DdimSchedule sched(schedule_options(o));
  const bool dpm = o.kind == SamplerKind::kDpmSolver2M;
  kernels::nn::DdimStep step_kernel(ctx);
  kernels::nn::DpmSolverStep dpm_kernel(ctx);
  kernels::nn::LatentOverwrite overwrite_kernel(ctx);
  const uint64_t bytes = d.n * 4, element_bytes = static_cast<uint64_t>(d.C + 8) * d.spatial * 4;
  const gpu::Buffer input = gpu::upload_vector(ctx, conditioned_batch(d, cond).data, "sampler denoiser input");
  const gpu::Buffer v(ctx, static_cast<uint64_t>(d.B) * bytes, gpu::MemoryUsage::DeviceLocal, "sampler prediction");
  std::optional<gpu::Buffer> v_uncond;
  const gpu::Buffer v_cond(ctx, bytes, gpu::MemoryUsage::DeviceLocal, "sampler conditional prediction");
  if (d.cfg) v_uncond.emplace(ctx, bytes, gpu::MemoryUsage::DeviceLocal, "sampler unconditional prediction");
  gpu::Buffer latent_a(ctx, bytes, gpu::MemoryUsage::DeviceLocal, "sampler latent");
  gpu::Buffer latent_b(ctx, bytes, gpu::MemoryUsage::DeviceLocal, "sampler latent");
  const gpu::Buffer z(ctx, bytes, gpu::MemoryUsage::DeviceLocal, "sampler noise");
  gpu::Buffer* x = &latent_a;
  gpu::Buffer* next = &latent_b;
  // DPM-Solver++: this step's data prediction and the previous step's.
  std::optional<gpu::Buffer> x0_a, x0_b;
  if (dpm) {
    x0_a.emplace(ctx, bytes, gpu::MemoryUsage::DeviceLocal, "sampler data prediction");
    x0_b.emplace(ctx, bytes, gpu::MemoryUsage::DeviceLocal, "sampler data prediction");
  }
  gpu::Buffer* x0 = dpm ? &*x0_a : nullptr;
  gpu::Buffer* x0_prev = dpm ? &*x0_b : nullptr;
  std::optional<gpu::Buffer> known_b, mask_b;
  if (d.outpaint) {
    known_b.emplace(gpu::upload_vector(ctx, known->values, "sampler known latents"));
    mask_b.emplace(gpu::upload_vector(ctx, known->mask, "sampler known mask"));
  }
  std::vector<float> host_noise(d.n);
  normal_noise({o.seed, chunk_index, 0, NoisePurpose::InitialLatent}, 0, host_noise.data(), d.n);
  gpu::upload(ctx, *x, host_noise.data(), bytes);
  // Orders the previous submission's kernel and copy writes (the denoiser's, the step's, uploads) before
  // this one's kernels and copies.
  auto after_previous = [](gpu::CommandList& cmd) { cmd.barrier(kWritesBeforeNextSubmission); };

  ChunkSample out;
  if (progress) progress(0, sched.size());
  for (size_t i = 0; i < sched.size(); ++i) {
    const DdimStep st = sched.step(i);
    const gpu::HostTransferBytes before = gpu::host_transfer_bytes();
    StepTiming timing;
    timing.t = st.t;
    float a = 0, s = 0;
    if (d.outpaint) {
      sched.noise_level(st.t, &a, &s);
      normal_noise({o.seed, chunk_index, static_cast<uint32_t>(st.t), NoisePurpose::KnownLatent}, 0, host_noise.data(), d.n);
      gpu::upload(ctx, z, host_noise.data(), bytes);
    }
    ctx.submit_and_wait([&](gpu::CommandList& cmd) {  // the known cells, then the latent into every batch element
      after_previous(cmd);
      if (d.outpaint) {
        overwrite_kernel.record(cmd, static_cast<uint32_t>(d.C), d.spatial, a, s, *known_b, *mask_b, z, *x);
        cmd.barrier(gpu::deps::kComputeToTransfer);
      }
      for (int64_t b = 0; b < d.B; ++b) cmd.copy_buffer(x->binding(0, bytes), input.binding(static_cast<uint64_t>(b) * element_bytes, bytes));
    });
    Clock::time_point t0 = Clock::now();
    denoiser.predict_on_device(ctx, input, d.input_shape(), st.t, v);
    timing.denoise_ms = ms_since(t0);
    t0 = Clock::now();
    const bool noise = !dpm && st.sigma != 0.0f;
    if (noise) {
      normal_noise({o.seed, chunk_index, static_cast<uint32_t>(st.t), NoisePurpose::StepNoise}, 0, host_noise.data(), d.n);
      gpu::upload(ctx, z, host_noise.data(), bytes);
    }
    ctx.submit_and_wait([&](gpu::CommandList& cmd) {  // the predictions apart, then the step
      after_previous(cmd);
      cmd.copy_buffer(v.binding(0, bytes), v_cond.binding(0, bytes));
      if (d.cfg) cmd.copy_buffer(v.binding(bytes, bytes), v_uncond->binding(0, bytes));
      cmd.barrier(gpu::deps::kTransferToCompute);
      const gpu::Buffer* uncond = d.cfg ? &*v_uncond : nullptr;
      if (dpm)
        dpm_kernel.record(cmd, dpm_solver_coefficients(sched, i), d.n, *x, v_cond, uncond, o.cfg_scale, x0_prev, *next, *x0);
      else
        step_kernel.record(cmd, st.coefficients(), d.n, *x, v_cond, uncond, o.cfg_scale, noise ? &z : nullptr, *next);
    });
    std::swap(x, next);
    std::swap(x0, x0_prev);
    timing.step_ms = ms_since(t0);
    timing.host_bytes = transferred_since(before);
    out.steps.push_back(timing);
    if (progress) progress(i + 1, sched.size());
  }
  if (d.outpaint && o.final_overwrite)  // b = 0 and z = the known latents themselves (finite): `known` exactly
    ctx.submit_and_wait([&](gpu::CommandList& cmd) {
      after_previous(cmd);
      overwrite_kernel.record(cmd, static_cast<uint32_t>(d.C), d.spatial, 1.0f, 0.0f, *known_b, *mask_b, *known_b, *x);
    });
  out.latent = nn::CpuTensor({1, d.C, d.X, d.Y, d.Z}, gpu::download_vector<float>(ctx, *x, d.n));
  return out;
}

}  // namespace

const char* sampler_kind_name(SamplerKind kind) { return kind == SamplerKind::kDpmSolver2M ? "dpm++2m" : "ddim"; }

DdimOptions schedule_options(const SamplerOptions& o) {
  DdimOptions d = o.ddim;
  if (o.kind == SamplerKind::kDpmSolver2M) d.spacing = TimestepSpacing::kLogSnr;
  return d;
}

void check_sampler_options(const SamplerOptions& o) {
  const DdimSchedule schedule(schedule_options(o));
  if (o.kind == SamplerKind::kDpmSolver2M && o.ddim.eta != 0.0f)
    throw std::invalid_argument("sampler dpm++2m is deterministic: eta " + std::to_string(o.ddim.eta) +
                                " applies to ddim only (use eta 0)");
}

bool KnownLatents::any() const { return std::any_of(mask.begin(), mask.end(), [](uint32_t m) { return m != 0; }); }

void Denoiser::predict_on_device(gpu::Context& ctx, const gpu::Buffer& x_in, const std::vector<int64_t>& x_shape, int t,
                       const gpu::Buffer& v) {
  nn::CpuTensor x(x_shape);
  x.data = gpu::download_vector<float>(ctx, x_in, x.data.size());
  const nn::CpuTensor y = predict(x, t);
  const bool same_grid = y.shape.size() == 5 && y.shape[0] == x_shape[0] && std::equal(y.shape.begin() + 2, y.shape.end(), x_shape.begin() + 2);
  if (!same_grid || static_cast<uint64_t>(y.numel()) * 4 != v.size())
    throw std::invalid_argument("sample_chunk: the denoiser returned a tensor of another shape than [B, C, X, Y, Z]");
  gpu::upload(ctx, v, y.data.data(), y.data.size() * 4);
}

ChunkSample sample_chunk(Denoiser& denoiser, int latent_channels, const nn::CpuTensor& cond, const KnownLatents* known,
                         uint32_t chunk_index, const SamplerOptions& o, gpu::Context* ctx,
                         const std::function<void(size_t, size_t)>& progress) {
  if (cond.shape.size() != 4 || cond.shape[0] != 8)
    throw std::invalid_argument("sample_chunk: the condition volume is not [8, X, Y, Z]");
  if (latent_channels < 1) throw std::invalid_argument("sample_chunk: " + std::to_string(latent_channels) + " latent channels");
  check_sampler_options(o);
  ChunkDims d;
  d.C = latent_channels;
  d.X = cond.shape[1];
  d.Y = cond.shape[2];
  d.Z = cond.shape[3];
  d.spatial = static_cast<size_t>(d.X * d.Y * d.Z);
  d.n = static_cast<size_t>(d.C) * d.spatial;
  d.outpaint = known && known->any();
  d.cfg = o.cfg_scale != 1.0f;
  d.B = d.cfg ? 2 : 1;
  if (d.outpaint && (known->mask.size() != d.spatial || known->values.size() != d.n))
    throw std::invalid_argument("sample_chunk: known latents of " + std::to_string(known->values.size()) + " values and " +
                                std::to_string(known->mask.size()) + " mask cells for a " + std::to_string(d.C) + " x " +
                                std::to_string(d.spatial) + " latent");
  return ctx ? sample_on_device(denoiser, d, cond, known, chunk_index, o, *ctx, progress)
             : sample_on_host(denoiser, d, cond, known, chunk_index, o, progress);
}

}  // namespace icube::diffusion
