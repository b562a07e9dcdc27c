// The GSM voxel heads' Gaussian decoding (InfiniCube feature2gs with
// gs_free_space "hard", engine/nn/gsm/voxel_heads_reference.cpp): each voxel's
// per_voxel x gs_dim raw values become per_voxel Gaussians,
//   mean     = voxel min corner + sigmoid(raw xyz) * voxel size
//   scale    = min(exp(raw) * scale_unit, max_scaling)   (no clamp when max_scaling <= 0)
//   rotation = raw quaternion / max(|raw quaternion|, 1e-12)
//   opacity  = sigmoid(raw)
//   colour   = the remaining gs_dim - 11 raw values
// Gaussian r * per_voxel + s is sub-Gaussian s of voxel r.
// GPU: GsmVoxelGaussians::record (shaders/nn/gsm_voxel_gaussians.comp), one
// invocation per Gaussian, float32, the outputs written from Gaussian
// first_gaussian on (a second head appends after the first). Tensors past one
// storage binding go in windows of subs and voxels, one dispatch each (the
// raw values' channel rows of one sub over all the head's voxels must fit
// one binding: ~2.4 M voxels on lavapipe's 128 MiB; checked). No barrier
// inside.
// CPU reference: nn::cpu::gsm_voxel_gaussians (double, rounded once).
// Tests: tests/nn/test_gsm_voxel_gaussians.cpp.
#pragma once

#include "gpu/buffer.h"
#include "gpu/commands.h"
#include "kernels/nn/cpu_tensor.h"

#include <array>
#include <cstdint>
#include <vector>

namespace icube::kernels::nn {

struct GsmVoxelGaussiansShape {
  uint32_t rows = 0;       // voxels
  uint32_t per_voxel = 1;  // Gaussians per voxel
  uint32_t gs_dim = 14;    // raw values per Gaussian (>= 12: xyz 3, scale 3, rotation 4, opacity 1, colour >= 1)
  uint32_t first_gaussian = 0;
  std::array<float, 3> voxel_size{1.0f, 1.0f, 1.0f};  // voxel centre = ijk * voxel_size + origin
  std::array<float, 3> origin{0.0f, 0.0f, 0.0f};
  float scale_unit = 1.0f;   // scales are exp(raw) times this (the official model: its voxel size)
  float max_scaling = 0.0f;  // <= 0: no clamp
};

// The output buffers: float [n][3], [n][3], [n][4], [n], [n][gs_dim - 11] for every Gaussian written.
struct GsmGaussianBuffers {
  const gpu::Buffer* means = nullptr;
  const gpu::Buffer* scales = nullptr;
  const gpu::Buffer* rotations = nullptr;
  const gpu::Buffer* opacities = nullptr;
  const gpu::Buffer* colors = nullptr;
};

class GsmVoxelGaussians {
 public:
  explicit GsmVoxelGaussians(gpu::Context& ctx);
  // raw float [per_voxel * gs_dim][rows] (channel-major: a head's output), ijk int32 [rows][3].
  // Tensors past one storage binding go in windows of subs and voxels (one dispatch each, independent: no
  // barrier between them); a head whose gs_dim channel rows of all its voxels exceed one window is refused.
  void record(gpu::CommandList& cmd, const GsmVoxelGaussiansShape& s, const gpu::Buffer& raw, const gpu::Buffer& ijk,
              const GsmGaussianBuffers& out);
  // Dispatches of the last record (tests: the windows were used).
  size_t last_dispatches() const { return last_dispatches_; }

 private:
  gpu::Context& ctx_;
  gpu::Program& program_;
  size_t last_dispatches_ = 0;
};

}  // namespace icube::kernels::nn

namespace icube::nn::cpu {

struct GsmGaussians {
  CpuTensor means, scales, rotations, opacities, colors;  // [n, 3], [n, 3], [n, 4], [n, 1], [n, gs_dim - 11]
};

// raw [rows, per_voxel * gs_dim] (row-major), ijk [rows * 3] -> rows * per_voxel Gaussians.
GsmGaussians gsm_voxel_gaussians(const CpuTensor& raw, const std::vector<int32_t>& ijk, int64_t per_voxel, int64_t gs_dim,
                                 const std::array<float, 3>& voxel_size, const std::array<float, 3>& origin,
                                 float scale_unit, float max_scaling);

}  // namespace icube::nn::cpu
