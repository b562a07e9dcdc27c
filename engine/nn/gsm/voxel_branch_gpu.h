// The GSM voxel branch on the GPU (gsm_small README step 5; the same
// computation as voxel_unet_reference.h and voxel_heads_reference.h), recorded
// through the network layer (nn/layer_recorder.h) into one command list:
//   lifter      the effective pixels' conv features averaged per first-hit voxel (kernels/nn/scatter_mean.h,
//               deterministic lists built on the host from the first-hit rows), lifter.mix_fc
//   U-Net       pre_conv; the hash tree's levels; 2x2x2 max pooling over the existing children; residual blocks
//               GroupNorm -> 3x3x3 submanifold conv (fused SiLU) twice + skip; the kl bottlenecks; decoding by
//               subdivision with the encoder features in front; the input voxels kept (voxel_unet_gpu.h)
//   heads       the 0.1 m children of the first-hit voxels, their centres projected into every view with the
//               masked conv features sampled and maxed over the views (kernels/nn/gsm_project_features.h), the
//               hybrid and 3-D heads on their own grids, the Gaussian decoding (kernels/nn/gsm_voxel_gaussians.h)
//               (voxel_heads_gpu.h)
// Structure is integer bookkeeping on the host, O(voxels), from the input ijk and the first-hit rows alone: the
// hash-tree levels, the decoder's children grids, the front masks and the children of the front voxels are
// built there in lexicographic order (the reference's rows) and uploaded with the row tables the GPU steps read
// (max pooling's children, subdivision's parents, encoder-feature lookups, the kept input voxels). Every
// feature operation runs on the GPU: the kernel maps are built there from the uploaded coordinates
// (kernels/nn/sparse_conv.h), row copies and max pooling are kernels/nn/sparse_grid.h's, the convolutions,
// norms and element-wise steps the LayerRecorder's. Nothing is read back.
// The first-hit rows (pixel rays, gsm_rays.h) stay a host input here.
// Weights: the GSM's GPU weights (gsm_gpu_weights.h), the fVDB 3x3x3 kernels in grid order under
// gsm_sparse_conv_grid_order(...).
// Tests: tests/nn/test_gsm_voxel_branch_gpu.cpp.
#pragma once

#include "gpu/context.h"
#include "kernels/nn/cpu_tensor.h"
#include "kernels/nn/sparse_cpu.h"
#include "nn/device_tensor.h"
#include "nn/gsm/gsm_trace.h"
#include "nn/gsm/gsm_weights.h"
#include "nn/gsm/voxel_heads_reference.h"
#include "nn/gsm/voxel_unet_reference.h"
#include "nn/layer_recorder.h"

#include <array>
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace icube::kernels::nn {
class GsmProjectFeatures;
class GsmVoxelGaussians;
class ScatterMean;
class SparseGridOps;
class SparseKernelMap;
}  // namespace icube::kernels::nn

namespace icube::nn {

// The prefix under which gsm_gpu_weights.cpp stores an fVDB 0.2.0 3x3x3 sparse kernel `<conv>.weight`
// converted to grid order (fvdb020_kernel_to_grid_order): "<conv>.grid_order" (weight "<conv>.grid_order.weight").
std::string gsm_sparse_conv_grid_order(const std::string& conv_prefix);
// Adds those converted kernels for every `backbone.backbone_3d.*.Conv.weight` of shape [Co, Ci, 3, 3, 3] in `w`
// (called by gsm_gpu_weights; the official tensors stay as they are).
void add_voxel_branch_gpu_tensors(const GsmWeights& w, std::map<std::string, CpuTensor>& tensors);

// A sparse grid of the voxel branch on the device: coordinates on both sides, the 3^3 kernel map.
struct VoxelGridGpu {
  SparseGrid host;
  std::shared_ptr<gpu::Buffer> ijk;   // int32 [rows][3]
  std::shared_ptr<gpu::Buffer> kmap;  // int32 [rows][27], -1 = no neighbour (null for an empty grid)
  uint32_t rows() const { return static_cast<uint32_t>(host.size()); }
};

// Intermediates under the reference's names: device features [1, C, rows] (channel-major) and host tensors
// (the `.ijk` of each sparse tensor, the front masks).
struct VoxelBranchGpuTrace {
  std::map<std::string, DeviceTensor> device;
  GsmTrace host;
  // After the command list ran: every device tensor as [rows, C] (the reference's layout) plus the host ones.
  GsmTrace download(gpu::Context& ctx) const;
};

// The voxel Gaussians of one batch element on the device (row-major per Gaussian), with their sources.
struct VoxelGaussiansGpu {
  DeviceTensor means, scales, rotations, opacities, colors;  // [n, 3], [n, 3], [n, 4], [n, 1], [n, gs_dim - 11]
  std::vector<int32_t> src_ijk;    // [n, 3]
  std::vector<int32_t> src_level;  // [n]: 0 = a child of a front voxel, 1 = another input voxel
  std::vector<int32_t> src_sub;    // [n]
  int64_t count() const { return static_cast<int64_t>(src_level.size()); }
  // After the command list ran: the reference's VoxelGaussians.
  VoxelGaussians download(gpu::Context& ctx) const;
};

// The kernels and the buffers one recording of the voxel branch needs. Steps record into L's current command
// list (between L.begin and L.end) and end with a barrier; the buffers they upload (coordinates, row tables,
// kernel maps) stay alive until release() or destruction, so keep this object until the list has run.
class VoxelBranchGpu {
 public:
  VoxelBranchGpu(gpu::Context& ctx, LayerRecorder& L);
  ~VoxelBranchGpu();
  VoxelBranchGpu(const VoxelBranchGpu&) = delete;
  VoxelBranchGpu& operator=(const VoxelBranchGpu&) = delete;

  gpu::Context& ctx() const { return ctx_; }
  LayerRecorder& L() const { return L_; }

  // Uploads the grid's coordinates and records its hash table and kernel map.
  VoxelGridGpu grid(const SparseGrid& g);
  // y [1, C, rows.size()] = x [1, C, N] at `rows` (-1: zeros).
  DeviceTensor gather_rows(const DeviceTensor& x, const std::vector<int32_t>& rows);
  // y [1, C, Q] = for each coarse row q the maximum of x's rows child_rows[8 q .. 8 q + 8) that are >= 0,
  // 0 where none is (the hash tree's pooling onto a coarse grid that may hold voxels without children).
  DeviceTensor max_pool_children(const DeviceTensor& x, const std::vector<int32_t>& child_rows);
  // A row-major [rows, channels] buffer (the scatter mean's) as the channel-major [1, channels, rows].
  DeviceTensor rows_to_channels(const DeviceTensor& x, int64_t rows, int64_t channels);

  // Host data uploaded for the recording (kept alive with it); empty vectors get a 4-byte buffer.
  const gpu::Buffer& upload(const std::vector<int32_t>& v, const std::string& name);
  const gpu::Buffer& upload(const std::vector<uint32_t>& v, const std::string& name);
  const gpu::Buffer& upload(const std::vector<float>& v, const std::string& name);

  kernels::nn::ScatterMean& scatter_mean();
  kernels::nn::GsmProjectFeatures& project_features();
  kernels::nn::GsmVoxelGaussians& voxel_gaussians();

  // Drops the kept buffers (after the recorded work finished).
  void release();

 private:
  struct Impl;
  gpu::Context& ctx_;
  LayerRecorder& L_;
  std::unique_ptr<Impl> impl_;
};

struct VoxelBranchGpuOutputs {
  DeviceTensor features;  // [1, f_maps, V]: the U-Net output on the input grid's rows (vox.out.b<i>)
  VoxelFrontMasks front;  // host
  VoxelGaussiansGpu gaussians;
};

// The whole voxel branch of one batch element: image_features [N, C, H, W] on the device (the conv encoder's),
// first_voxel [N * H * W] (gsm_rays.h), effective_mask [N, H, W] (> 0 = effective), the views' poses and
// intrinsics. Records into B's LayerRecorder; traces as the references do.
VoxelBranchGpuOutputs voxel_branch_gpu(VoxelBranchGpu& B, const VoxelUnetConfig& unet, const VoxelHeadsConfig& heads,
                                       const SparseGrid& grid, const DeviceTensor& image_features,
                                       const std::vector<int32_t>& first_voxel, const CpuTensor& effective_mask,
                                       const std::vector<std::array<float, 16>>& poses,
                                       const std::vector<std::array<float, 6>>& intrinsics, int batch_index,
                                       VoxelBranchGpuTrace* trace);

}  // namespace icube::nn
