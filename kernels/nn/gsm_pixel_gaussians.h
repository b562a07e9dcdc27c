// The GSM pixel branch's Gaussian decoding (InfiniCube Pure2DUNet; gsm_small
// README step 6), dense over every pixel: from the per-pixel linear layer's raw
// values, gs_per_pixel Gaussians of gs_dim raw values each (depth 1, scale 3,
// rotation 4, opacity 1, colour gs_dim - 9), decoded as
//   ray       pixel (col, row) at integer coordinates through the camera-to-grid
//             pose: d = float(P [(col - cx) / fx, (row - cy) / fy, 1, 1]^T)[:3] - t,
//             dir = d / |d| (float32, as the official create_rays_from_intrinsic)
//   mean      t + depth / <pose z axis, dir> dir, depth = sigmoid(raw) (zfar - znear)
//             + znear ("weight") or 1 / sigmoid(raw) ("inverse_metric_depth")
//   scale     min(exp(raw - 2.3), max_scale); rotation raw / max(|raw|, 1e-12);
//   opacity   sigmoid(raw - 1); colour raw
// each Gaussian as gs_dim + 2 floats (mean 3, scale 3, rotation 4, opacity 1,
// colour gs_dim - 9: 14 for the release), plus each pixel's keep value: fg -
// fg * grid_fg (mid-ground: segmentation foreground the voxel grid does not
// cover) or fg; a pixel keeps its Gaussians where the value is > 0. Picking the
// kept pixels in (view, row, column) order is left to the caller (an ordered
// copy on the host: nn::compact_pixel_gaussians in engine/nn/gsm/pixel_branch_gpu.h).
// GPU: GsmPixelGaussians::record (shaders/nn/gsm_pixel_gaussians.comp), one
// invocation per pixel, one dispatch per view (each view's tensors must fit one
// storage binding); no barrier inside.
// CPU reference: nn::cpu::gsm_pixel_gaussians (gsm_pixel_gaussians_cpu.cpp, in
// double where the reference decoder, engine/nn/gsm/pixel_branch_reference.cpp,
// uses double). Tests: tests/nn/test_gsm_pixel_gaussians.cpp.
#pragma once

#include "gpu/buffer.h"
#include "gpu/commands.h"
#include "kernels/nn/cpu_tensor.h"

#include <array>
#include <cstdint>
#include <vector>

namespace icube::kernels::nn {

struct GsmPixelGaussiansShape {
  uint32_t views = 1, height = 1, width = 1;
  uint32_t gs_per_pixel = 2, gs_dim = 12;  // gs_dim >= 10
  float znear = 0.5f, zfar = 300.0f, max_scale = 0.1f;
  bool inverse_metric_depth = false;  // interpret_output_depth: false = "weight"
  bool midground_only = true;         // keep fg - fg * grid_fg (with the voxel branch), else fg

  uint32_t record_floats() const { return gs_dim + 2; }  // floats per decoded Gaussian
  uint64_t pixels() const { return uint64_t{height} * width; }
};

// Floats per view in the camera buffer (NN_GSMPIX_CAMERA_FLOATS).
uint32_t gsm_pixel_camera_floats();
// The camera buffer's content: per view the camera-to-grid pose (row-major 4x4), then fx, fy, cx, cy.
std::vector<float> pack_gsm_pixel_cameras(const std::vector<std::array<float, 16>>& poses,
                                          const std::vector<std::array<float, 6>>& intrinsics);

class GsmPixelGaussians {
 public:
  explicit GsmPixelGaussians(gpu::Context& ctx);
  // params [views, gs_per_pixel * gs_dim, H * W] (channel-major, the linear layer's output as a 1x1
  // convolution), foreground and grid_foreground [views, H * W] (0 / 1), cameras (pack_gsm_pixel_cameras)
  // -> gaussians [views, H * W, gs_per_pixel, gs_dim + 2] and mask [views, H * W]. The caller orders the
  // inputs before and the outputs after.
  void record(gpu::CommandList& cmd, const GsmPixelGaussiansShape& s, const gpu::Buffer& params, const gpu::Buffer& foreground,
              const gpu::Buffer& grid_foreground, const gpu::Buffer& cameras, const gpu::Buffer& gaussians,
              const gpu::Buffer& mask);

 private:
  gpu::Context& ctx_;
  gpu::Program& program_;
};

}  // namespace icube::kernels::nn

namespace icube::nn::cpu {

struct GsmPixelGaussiansDense {
  CpuTensor gaussians;  // [views, H, W, gs_per_pixel, gs_dim + 2]
  CpuTensor mask;       // [views, H, W]
};

// The same decoding as GsmPixelGaussians::record on the CPU: params [views, gs_per_pixel * gs_dim, H, W]
// (or [..., H * W]), foreground and grid_foreground views * H * W values, cameras pack_gsm_pixel_cameras.
GsmPixelGaussiansDense gsm_pixel_gaussians(const kernels::nn::GsmPixelGaussiansShape& s, const CpuTensor& params,
                                           const std::vector<float>& foreground, const std::vector<float>& grid_foreground,
                                           const std::vector<float>& cameras);

}  // namespace icube::nn::cpu
