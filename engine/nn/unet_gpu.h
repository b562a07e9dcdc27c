// InfiniCube's dense diffusion UNet on the GPU: the module tree of
// UNetReference recorded as kernels/nn dispatches into one command list
// (conv3d, group_norm with fused scale-shift/SiLU, layer_norm_channels,
// attention, elementwise, resample; linears as 1x1 convolutions on
// channels-first tensors, the time-embedding sinusoid on the host), with a
// barrier after every dispatch. fp32 storage. Weights are packed and uploaded
// once. Intermediates get their own buffers for now (the liveness memory plan
// is to come); block outputs can be captured under the names of
// unet_small/*.intermediates.safetensors. Every tensor must fit one storage
// binding except conv3d's (which windows).
// Tests: tests/nn/test_unet_gpu.cpp (against the official reference case and
// the CPU reference).
#pragma once

#include "gpu/context.h"
#include "nn/cpu_tensor.h"
#include "nn/unet_reference.h"

#include <map>
#include <memory>
#include <string>
#include <vector>

namespace icube::nn {

class UNetGpu {
 public:
  // `weights` by official name, as UNetReference::set_weights takes them.
  UNetGpu(gpu::Context& ctx, const UNetConfig& config, const std::map<std::string, CpuTensor>& weights);
  ~UNetGpu();
  UNetGpu(const UNetGpu&) = delete;
  UNetGpu& operator=(const UNetGpu&) = delete;

  // x [B, in_channels, X, Y, Z], t [B] -> [B, out_channels, X, Y, Z]; capture as UNetReference::forward.
  CpuTensor forward(const CpuTensor& x, const std::vector<int64_t>& t, const UNetReference::Capture& capture = {});
  // Device bytes of the intermediates of the last forward (all kept alive; no memory plan yet).
  uint64_t last_activation_bytes() const { return activation_bytes_; }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  uint64_t activation_bytes_ = 0;
};

}  // namespace icube::nn
