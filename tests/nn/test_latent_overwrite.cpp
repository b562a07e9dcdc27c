// Outpainting's overwrite on the GPU (kernels/nn/latent_overwrite.h) against
// its CPU reference: exactly the masked voxels of every channel change, to the
// noised known latents. Runs under the validation layer.
#include <doctest/doctest.h>

#include "diffusion/ddim_schedule.h"
#include "gpu_test_context.h"
#include "nn/random_vector.h"
#include "kernels/nn/latent_overwrite.h"

#include <random>

using namespace icube;

using test::random_vector;

TEST_CASE("latent overwrite gpu: replaces exactly the masked voxels of every channel, as the CPU reference") {
  gpu::Context& ctx = test::gpu_context();
  kernels::nn::LatentOverwrite overwrite(ctx);
  const uint32_t channels = 3;
  const uint64_t spatial = 7 * 11 * 5;
  const size_t n = channels * spatial;
  std::vector<uint32_t> mask(spatial);
  std::mt19937 rng(9);
  for (uint32_t& m : mask) m = rng() % 3 == 0 ? 1u : 0u;
  const std::vector<float> x = random_vector(n, 1.0f, 5), known = random_vector(n, 2.0f, 6), z = random_vector(n, 1.0f, 7);
  float sa = 0, sb = 0;
  diffusion::DdimSchedule({}).noise_level(990, &sa, &sb);
  std::vector<float> want = x;
  nn::cpu::latent_overwrite(want, mask, known, sa, sb, &z);
  size_t changed = 0;
  for (size_t i = 0; i < n; ++i) changed += want[i] != x[i];
  CHECK(changed > n / 4);
  gpu::Buffer xb = gpu::upload_vector(ctx, x, "x"), kb = gpu::upload_vector(ctx, known, "known"),
              mb = gpu::upload_vector(ctx, mask, "mask"), zb = gpu::upload_vector(ctx, z, "z");
  ctx.submit_and_wait([&](gpu::CommandList& cmd) { overwrite.record(cmd, channels, spatial, sa, sb, kb, mb, zb, xb); });
  CHECK(test::allclose(gpu::download_vector<float>(ctx, xb, n), want, 1e-6, 1e-6, "latent_overwrite"));
}

TEST_CASE("latent overwrite gpu: a latent over one storage binding runs in element windows, bit for bit") {
  // Bindings of 1600 bytes (the 385-voxel mask fits whole): 3 channels in windows of 396 that start inside a
  // channel, so each window finds its voxels from its first element.
  gpu::Context& ctx = test::gpu_context();
  const uint32_t channels = 3;
  const uint64_t spatial = 7 * 11 * 5;
  const size_t n = channels * spatial;
  std::vector<uint32_t> mask(spatial);
  for (size_t v = 0; v < spatial; ++v) mask[v] = v % 3 == 1 ? 1u : 0u;
  const std::vector<float> x = random_vector(n, 1.0f, 5), known = random_vector(n, 2.0f, 6), z = random_vector(n, 1.0f, 7);
  std::vector<float> want = x;
  nn::cpu::latent_overwrite(want, mask, known, 0.6f, 0.8f, &z);
  gpu::Buffer kb = gpu::upload_vector(ctx, known), mb = gpu::upload_vector(ctx, mask), zb = gpu::upload_vector(ctx, z);
  gpu::Buffer xb = gpu::upload_vector(ctx, x);
  kernels::nn::LatentOverwrite overwrite(ctx);
  overwrite.set_max_binding_bytes(1600);
  ctx.submit_and_wait([&](gpu::CommandList& cmd) { overwrite.record(cmd, channels, spatial, 0.6f, 0.8f, kb, mb, zb, xb); });
  CHECK(test::allclose(gpu::download_vector<float>(ctx, xb, n), want, 1e-6, 1e-6, "latent_overwrite windows"));
  // A mask over one binding goes in windows too (bindings of 256 bytes: windows inside each channel,
  // each binding the mask's voxels it covers at an aligned offset).
  gpu::Buffer xb2 = gpu::upload_vector(ctx, x);
  overwrite.set_max_binding_bytes(256);
  ctx.submit_and_wait([&](gpu::CommandList& cmd) { overwrite.record(cmd, channels, spatial, 0.6f, 0.8f, kb, mb, zb, xb2); });
  CHECK(test::allclose(gpu::download_vector<float>(ctx, xb2, n), want, 1e-6, 1e-6, "latent_overwrite mask windows"));
}
