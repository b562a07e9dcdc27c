// InfiniCube's dense diffusion UNet on the GPU: the module tree of
// UNetReference walked over the shared network layers (nn/layer_recorder.h:
// conv3d, group_norm with fused scale-shift/SiLU, layer_norm, attention,
// elementwise, resample; linears as 1x1 convolutions on channels-first
// tensors, the time-embedding sinusoid on the host) into one command list,
// a barrier after every layer; parameters in one nn::ParameterStore.
// Activations in fp32; weights in fp32 or, with
// Precision::F16Weights, the convolution and linear weights stored as fp16
// (half the weight memory; accumulation, norms and softmax stay fp32; biases
// and norm parameters fp32); Precision::F16 stores the convolutions' input
// operands (the GroupNorm and LayerNorm outputs) as fp16 too
// (nn/network_precision.h). Weights are packed and uploaded
// once. Activations live in the layers' pool: a buffer is reused as soon as the tensor
// in it is dead (liveness from the handles the recording holds), so the peak
// is near the largest live set (the skip connections and the current block),
// not the sum of all layers. Block outputs can be captured under the names of
// unet_small/*.intermediates.safetensors. Tensors beyond one storage binding
// (the released model's 64^3 levels) run in windows in conv3d, GroupNorm, the
// element-wise add / SiLU / GEGLU and the resampling; attention and LayerNorm
// (16^3 and 8^3 levels) need one binding.
// Tests: tests/nn/test_unet_gpu.cpp (against the official reference case and
// the CPU reference).
#pragma once

#include "gpu/buffer.h"
#include "gpu/context.h"
#include "kernels/nn/cpu_tensor.h"
#include "nn/unet_reference.h"
#include "nn/network_precision.h"

#include <map>
#include <memory>
#include <string>
#include <vector>

namespace icube::nn {

class UNetGpu {
 public:
  using Precision = NetworkPrecision;
  // `weights` by official name, as UNetReference::set_weights takes them.
  UNetGpu(gpu::Context& ctx, const UNetConfig& config, const std::map<std::string, CpuTensor>& weights,
          Precision precision = Precision::F32);
  ~UNetGpu();
  UNetGpu(const UNetGpu&) = delete;
  UNetGpu& operator=(const UNetGpu&) = delete;

  // x [B, in_channels, X, Y, Z], t [B] -> [B, out_channels, X, Y, Z]; capture as UNetReference::forward.
  CpuTensor forward(const CpuTensor& x, const std::vector<int64_t>& t, const UNetReference::Capture& capture = {});
  // The same on device buffers the caller owns: x [B, in_channels, X, Y, Z] (x_shape) in `x`, the
  // prediction [B, out_channels, X, Y, Z] written to the start of `y`. One submission, waited for; only
  // the timesteps' sinusoidal embedding (B x model_channels floats) goes from the host to the device.
  void forward(const gpu::Buffer& x, const std::vector<int64_t>& x_shape, const std::vector<int64_t>& t, const gpu::Buffer& y);
  // Peak device bytes of the activation pool in the last forward (inputs and weights not counted).
  uint64_t last_activation_bytes() const { return activation_bytes_; }
  // FLOPs of the last forward's convolutions, linears and attention (LayerRecorder::matmul_flops).
  uint64_t last_matmul_flops() const { return matmul_flops_; }
  // Tests: conv3d, GroupNorm, the element-wise and resampling kernels window as if one
  // binding held at most `bytes` (0 = the device's limit).
  void set_max_binding_bytes(uint64_t bytes);
  // Device bytes of the uploaded parameters.
  uint64_t weight_bytes() const { return weight_bytes_; }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  uint64_t activation_bytes_ = 0;
  uint64_t matmul_flops_ = 0;
  uint64_t weight_bytes_ = 0;
};

}  // namespace icube::nn
