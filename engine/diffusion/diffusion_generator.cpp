// The UNet + VAE Stage-1 generator; see diffusion_generator.h.
#include "diffusion/diffusion_generator.h"

#include "diffusion/decoded_chunk.h"
#include "diffusion/unet_denoiser.h"
#include "gpu/context.h"
#include "nn/vae_gpu.h"
#include "scene/input_error.h"
#include "world/conditions.h"
#include "world/conditions_gpu.h"
#include "world/npy.h"
#include "world/road_surface.h"

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <stdexcept>

namespace icube::diffusion {

namespace {

using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

}  // namespace

struct DiffusionGenerator::Impl {
  gpu::Context& ctx;
  const scene::Scene& scene;
  DiffusionGeneratorOptions options;
  int latent_channels;
  world::RoadSurface surface;
  nn::UNetGpu unet;
  nn::VaeGpu vae;
  world::ConditionVolumeGpu conditions;
  // Changed by the const generate(): chunks run one at a time in plan order (reads_world()).
  LatentStore store;
  std::vector<ChunkTiming> timings;
  uint64_t peak_activations = 0;

  Impl(gpu::Context& c, const scene::Scene& s, world::PlanMode mode, const nn::UNetConfig& unet_cfg,
       const std::map<std::string, nn::CpuTensor>& unet_w, const nn::VaeConfig& vae_cfg,
       const std::map<std::string, nn::CpuTensor>& vae_w, const DiffusionGeneratorOptions& o)
      : ctx(c),
        scene(s),
        options(o),
        latent_channels(vae_cfg.latent_channels()),
        surface(world::build_road_surface(s.map, world::RoadSurfaceOptions{})),
        unet(c, unet_cfg, unet_w, o.precision),
        vae(c, vae_cfg, vae_w, o.precision),
        conditions(c),
        store(mode, vae_cfg.latent_channels()) {}
};

DiffusionGenerator::DiffusionGenerator(gpu::Context& ctx, const scene::Scene& scene, world::PlanMode mode,
                                       const nn::UNetConfig& unet, const std::map<std::string, nn::CpuTensor>& unet_weights,
                                       const nn::VaeConfig& vae, const std::map<std::string, nn::CpuTensor>& vae_weights,
                                       const DiffusionGeneratorOptions& options) {
  // The UNet sees the latent and the 8 condition channels and predicts the latent's v.
  const int c = vae.latent_channels();
  if (unet.in_channels != c + world::kCondChannels || unet.outputs() != c)
    throw std::invalid_argument("diffusion: the UNet takes " + std::to_string(unet.in_channels) + " channels and predicts " +
                                std::to_string(unet.outputs()) + ", the VAE's latent has " + std::to_string(c) +
                                " (the UNet needs " + std::to_string(c + world::kCondChannels) + " in, " + std::to_string(c) +
                                " out)");
  if (!(options.scale_factor > 0.0)) throw std::invalid_argument("diffusion: scale_factor must be positive");
  check_sampler_options(options.sampler);  // bad steps / eta: an error before any work
  impl_ = std::make_unique<Impl>(ctx, scene, mode, unet, unet_weights, vae, vae_weights, options);
}

DiffusionGenerator::~DiffusionGenerator() = default;

const std::vector<ChunkTiming>& DiffusionGenerator::timings() const { return impl_->timings; }

uint64_t DiffusionGenerator::peak_device_bytes() const {
  return impl_->unet.weight_bytes() + impl_->vae.weight_bytes() + impl_->peak_activations;
}

world::ChunkVoxels DiffusionGenerator::generate(const world::ChunkRequest& request) const {
  Impl& m = *impl_;
  const world::ChunkPose& pose = request.plan->chunks.at(request.chunk);
  const world::ChunkInfo& info = request.plan->info.at(request.chunk);
  ChunkTiming timing;

  // Conditions: static boxes at the key's time (trajectory) or the first timestamp.
  Clock::time_point t0 = Clock::now();
  world::ConditionOptions copt;
  copt.time_index = std::max(info.time_index, 0);
  const std::vector<float> volume = m.conditions.build(world::gather_condition_inputs(m.scene, pose, m.surface, copt));
  const int64_t d = world::kLatentDim;
  const nn::CpuTensor cond({world::kCondChannels, d, d, d}, volume);
  timing.conditions_ms = ms_since(t0);

  // Sampling with the earlier chunks' latents as known cells.
  t0 = Clock::now();
  const KnownLatents known = m.store.known_for(pose);
  for (const uint32_t k : known.mask) timing.known_cells += k;
  UNetDenoiser denoiser(m.unet);
  const size_t chunk_index = request.chunk;
  const ChunkSample sample =
      sample_chunk(denoiser, m.latent_channels, cond, &known, static_cast<uint32_t>(request.chunk), m.options.sampler, &m.ctx,
                   [&](size_t done, size_t total) {
                     if (m.options.progress) m.options.progress(chunk_index, done, total);
                   });
  m.peak_activations = std::max(m.peak_activations, m.unet.last_activation_bytes());
  timing.sample_ms = ms_since(t0);
  m.store.add(pose, sample.latent.data);
  if (!m.options.keep_latents.empty()) {
    std::filesystem::create_directories(m.options.keep_latents);
    char name[32];
    std::snprintf(name, sizeof(name), "chunk_%04zu.npy", request.chunk);
    world::write_npy((std::filesystem::path(m.options.keep_latents) / name).string(),
                     world::NpyArray::make<float>({1, static_cast<uint64_t>(m.latent_channels), 64, 64, 64}, sample.latent.data));
  }

  // Decode: the latent grid is the dense 64^3 box [-32, 32)^3 at the latent voxel, fVDB origin vs / 2.
  t0 = Clock::now();
  std::vector<float> z = sample.latent.data;
  for (float& v : z) v = static_cast<float>(static_cast<double>(v) / m.options.scale_factor);
  const std::array<double, 3> vs{world::kLatentVoxel.x, world::kLatentVoxel.y, world::kLatentVoxel.z};
  const nn::SparseGrid grid = nn::dense_box_grid({-32, -32, -32}, {64, 64, 64}, vs, {vs[0] / 2, vs[1] / 2, vs[2] / 2});
  const nn::SparseTensor latent =
      nn::cpu::from_dense(nn::CpuTensor({1, m.latent_channels, d, d, d}, std::move(z)), {-32, -32, -32}, grid);
  const nn::VaeDecoded decoded = m.vae.decode(latent);
  m.peak_activations = std::max(m.peak_activations, m.vae.last_activation_bytes());
  timing.warning = decoded.warning;
  world::ChunkVoxels out = decoded_chunk(decoded, pose.chunk_to_world);
  timing.voxels = out.voxels.size();
  timing.decode_ms = ms_since(t0);
  if (m.timings.size() <= request.chunk) m.timings.resize(request.chunk + 1);
  m.timings[request.chunk] = timing;
  return out;
}

}  // namespace icube::diffusion
