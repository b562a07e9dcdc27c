// Stage 1's sampler for one chunk (conventions §9.1-9.3): the chunk's latent
// [C, X, Y, Z] starts as counter-based noise and is denoised by DDIM over the
// schedule (or DPM-Solver++ 2M over the same timesteps: SamplerKind); at every step the denoiser sees the latent concatenated with the
// chunk's condition volume [8, X, Y, Z] (position, map and box channels,
// world/conditions.h) and predicts v. With guidance scale s != 1 a second,
// unconditional input (map and box channels zeroed, positions kept) runs in
// the same batch and v = cond + s (cond - uncond) (InfiniCube's form; s = 1 is
// one pass). Outpainting: before every denoiser call the known latents
// (clean, in the diffusion model's scaled space) are noised to the current
// level with fresh noise and overwrite their cells; after the last step the
// known cells are set to the clean known latents (the step to alpha_prev = 1),
// so an overlap carries exactly the latents already generated — upstream stops
// at the model's last prediction there, which the fusion's "existing voxels
// win" hides in the world anyway.
// Noise: diffusion/counter_noise.h, streams (seed, chunk, timestep, purpose):
// a chunk is the same on any device and in any order.
// With a context the latent stays on the device from the initial noise to the
// last step: the guidance batch is assembled there (the condition channels
// uploaded once, the latent copied into each batch element), the denoiser
// reads and writes device buffers, the step and the overwrite are kernels
// (kernels/nn/ddim_step.h, latent_overwrite.h), and the latent comes back once, at the end.
// Per step only what the host makes crosses: the noise a step needs (eta > 0,
// outpainting's known-cell noise) and the denoiser's own (the UNet's timestep
// embedding). Without a context the CPU references run.
// Tests: tests/diffusion/test_chunk_sampler.cpp.
#pragma once

#include "diffusion/ddim_schedule.h"
#include "kernels/nn/cpu_tensor.h"

#include <cstdint>
#include <functional>
#include <vector>

namespace icube::gpu {
class Buffer;
class Context;
}  // namespace icube::gpu

namespace icube::diffusion {

// v-prediction for a batch: x_in [B, C + 8, X, Y, Z] at integer timestep t -> [B, C, X, Y, Z].
class Denoiser {
 public:
  virtual ~Denoiser() = default;
  virtual nn::CpuTensor predict(const nn::CpuTensor& x_in, int t) = 0;
  // The same on device buffers: x_in (shape x_shape) -> v written to the start of `v`. The default reads
  // x_in back, calls predict() and uploads its result (a host denoiser); UNetDenoiser stays on the device.
  virtual void predict_on_device(gpu::Context& ctx, const gpu::Buffer& x_in, const std::vector<int64_t>& x_shape, int t,
                       const gpu::Buffer& v);
};

// Condition channels zeroed in the unconditional input (world/conditions.h: 3..7 = map and boxes).
inline constexpr int kUncondFirstChannel = 3;

struct KnownLatents {
  std::vector<uint32_t> mask;  // per voxel (X * Y * Z), 1 = known
  std::vector<float> values;   // [C][X * Y * Z], clean latents times scale_factor
  bool any() const;
};

// The solver that takes the latent from noise to the sample, over the same timesteps (ddim's steps).
enum class SamplerKind {
  kDdim,         // DDIM with ddim.eta (the official sampler)
  kDpmSolver2M,  // DPM-Solver++ (2M) on log-SNR-uniform timesteps, deterministic: ddim.eta must be 0
                 // (diffusion/dpm_solver.h)
};
const char* sampler_kind_name(SamplerKind kind);  // "ddim", "dpm++2m"

struct SamplerOptions {
  SamplerKind kind = SamplerKind::kDdim;
  DdimOptions ddim;  // timesteps, schedule and DDIM's eta
  float cfg_scale = 1.0f;
  uint64_t seed = 0;
  bool final_overwrite = true;  // set the known cells to the clean known latents after the last step
};

// The schedule the sampler runs: ddim's, with log-SNR spacing for DPM-Solver++.
DdimOptions schedule_options(const SamplerOptions& options);

// std::invalid_argument on options no sampler can run (the schedule's own checks; eta != 0 with DPM-Solver++).
void check_sampler_options(const SamplerOptions& options);

struct StepTiming {
  int t = 0;
  double denoise_ms = 0.0, step_ms = 0.0;
  uint64_t host_bytes = 0;  // bytes between host and device during the step (gpu::host_transfer_bytes), 0 on the CPU
};

struct ChunkSample {
  nn::CpuTensor latent;  // [1, C, X, Y, Z] in the diffusion model's space (divide by scale_factor to decode)
  std::vector<StepTiming> steps;
};

// cond: [8, X, Y, Z]. progress(0, n) before the first step, progress(i, n) after each. Throws std::invalid_argument on shapes that do not
// fit (cond not 8 channels, known arrays of the wrong length) and on DPM-Solver++ with eta != 0.
ChunkSample sample_chunk(Denoiser& denoiser, int latent_channels, const nn::CpuTensor& cond, const KnownLatents* known,
                         uint32_t chunk_index, const SamplerOptions& options, gpu::Context* ctx = nullptr,
                         const std::function<void(size_t, size_t)>& progress = {});

}  // namespace icube::diffusion
