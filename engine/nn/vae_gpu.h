// InfiniCube's sparse structure VAE (decoder and encoder) on the GPU: VaeReference's
// module tree walked over the shared network layers (nn/layer_recorder.h:
// sparse_conv over one kernel map per level, the 1x1 convolutions, GroupNorm
// over the active voxels and the element-wise kernels on the channel-major
// [1, C, N] features), one command list per level with a barrier after every dispatch;
// between levels the structure decision, subdivision and feature copy run on
// the GPU (kernels/nn/sparse_grid.h), and only the structure logits and grids
// come back for the result (and the kept count, to size the next level).
// Activations are pooled as in UNetGpu (a buffer is reused once the tensor in
// it is dead), so the peak is near the largest live set of a level.
// Weights as VaeReference takes them (official names, 3^3 kernels already in
// grid order: vae_weights.h), in one nn::ParameterStore, packed and uploaded
// once, in fp32 or (Precision::F16Weights, F16) fp16: the sparse and 1x1
// convolutions' fp16-weight paths, tensor cores on NVIDIA GPUs; with
// Precision::F16 the GroupNorm outputs the convolutions read are fp16 too.
// Tensors beyond one storage binding (lavapipe: 128 MiB; a full chunk's finest
// level is ~2.7 M rows) run in windows: sparse_conv by row and channel
// windows, GroupNorm by groups or, for one group beyond a binding, in spans.
// Tests: tests/nn/test_vae_gpu.cpp (the official vae_small case and the CPU
// reference of a random-weight model).
#pragma once

#include "gpu/context.h"
#include "kernels/nn/cpu_tensor.h"
#include "nn/vae_config.h"
#include "nn/vae_reference.h"
#include "nn/network_precision.h"

#include <map>
#include <memory>
#include <string>
#include <vector>

namespace icube::nn {

class VaeGpu {
 public:
  using Precision = NetworkPrecision;
  VaeGpu(gpu::Context& ctx, const VaeConfig& config, const std::map<std::string, CpuTensor>& weights,
         Precision precision = Precision::F32);
  ~VaeGpu();
  VaeGpu(const VaeGpu&) = delete;
  VaeGpu& operator=(const VaeGpu&) = delete;

  // As VaeReference::decode: the latent's rows (any order) and channels [N, latent channels].
  VaeDecoded decode(const SparseTensor& latent);
  // As VaeReference::encode: mu on the dense neck box (brick order). The position embedding and class
  // embedding are made on the host (double sin/cos rounded to float32, as upstream's float32 torch is
  // within an ulp of), everything from mix_fc on runs on the GPU: max pooling onto the coarsened grids,
  // the neck box filled by hash lookups.
  SparseTensor encode(const SparseGrid& fine_grid, const std::vector<int32_t>& classes);

  // Peak device bytes of the activation pool in the last run (grids, kernel maps and weights not counted).
  uint64_t last_activation_bytes() const;
  // Wall time of each stage of the last run (submission + wait, host work around it), with its rows.
  struct Stage {
    std::string label;
    uint32_t rows = 0;
    double ms = 0.0;
  };
  const std::vector<Stage>& last_stages() const;
  uint64_t weight_bytes() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace icube::nn
