// The layers every GPU network is made of, recorded into one command list:
// each takes device tensors and the official name prefix of its parameters
// (looked up in the network's ParameterStore), allocates its output from the
// network's ActivationPool, dispatches its kernels/nn kernel and ends with a
// compute-to-compute barrier (so a pooled buffer can be reused by the next
// layer). A network is its module tree walked over these calls (UNetGpu,
// VaeGpu); a new one declares its layers and their order. Weights stored as
// fp16 (ParameterStoreOptions::f16_matrices) go to the dense and sparse
// convolutions' fp16-weight paths (tensor cores where the device has them).
// With set_f16_conv_operands, GroupNorm and LayerNorm store their outputs as
// fp16 (NetworkPrecision::F16): the convolutions read fp16 tensors as texels,
// every other layer refuses one (a network whose norm feeds anything but a
// convolution or linear keeps fp32 operands).
// Tests: through the networks (tests/nn/test_unet_gpu.cpp, test_vae_gpu.cpp,
// against the official cases and the CPU references).
#pragma once

#include "gpu/commands.h"
#include "kernels/nn/batch_norm.h"
#include "kernels/nn/interpolate.h"
#include "nn/activation_pool.h"
#include "nn/device_tensor.h"
#include "nn/parameter_store.h"

#include <memory>
#include <string>

namespace icube::kernels::nn {
class Attention;
class BatchNorm;
class Conv2d;
class Conv3d;
class Interpolate;
class Elementwise;
class GroupNorm;
class LayerNorm;
class Resample;
class SparseConv3d;
}  // namespace icube::kernels::nn

namespace icube::nn {

struct NormOptions {
  uint32_t groups = 32;  // GroupNorm only
  float eps = 1e-5f;
  bool silu = false;                         // y = silu(norm(x)), fused
  const DeviceTensor* modulation = nullptr;  // GroupNorm: [B, 2C] (scale, shift): y = norm(x) (1 + scale) + shift
  bool fp32_output = false;  // the output feeds a layer other than a convolution: fp32 under set_f16_conv_operands
};

class LayerRecorder {
 public:
  LayerRecorder(gpu::Context& ctx, const ParameterStore& params, const std::string& pool_name);
  ~LayerRecorder();
  LayerRecorder(const LayerRecorder&) = delete;
  LayerRecorder& operator=(const LayerRecorder&) = delete;

  // Layers record into `cmd` until end(); tensors allocated before stay valid across command lists.
  void begin(gpu::CommandList& cmd) { cmd_ = &cmd; }
  void end() { cmd_ = nullptr; }
  gpu::CommandList& cmd() const;
  gpu::Context& context() const { return ctx_; }
  void barrier() const;

  DeviceTensor alloc(std::vector<int64_t> shape, bool f16 = false);
  // GroupNorm and LayerNorm outputs as fp16 from now on (the convolutions' operands). Refused on a device
  // without 16-bit storage (std::invalid_argument), so a network asks before any work.
  void set_f16_conv_operands(bool on);
  ActivationPool& pool() { return pool_; }
  const ParameterStore& params() const { return params_; }

  // Dense convolution (3^3 or 1^3, zero padding) or linear (a 1^3 convolution on [B, C, tokens]) by the
  // weight's shape, plus `prefix.bias` when the network has one.
  DeviceTensor conv(const DeviceTensor& x, const std::string& prefix);
  // Sparse 3^3 convolution of features [1, C, rows] over a level's kernel map [rows][27] (+ bias when
  // present, optional fused SiLU).
  DeviceTensor sparse_conv(const DeviceTensor& x, const std::string& prefix, const gpu::Buffer& kernel_map, bool silu);
  DeviceTensor group_norm(const DeviceTensor& x, const std::string& prefix, const NormOptions& o);
  DeviceTensor layer_norm(const DeviceTensor& x, const std::string& prefix, float eps);  // over channels of [B, C, tokens]
  DeviceTensor silu(const DeviceTensor& x);
  DeviceTensor add(const DeviceTensor& a, const DeviceTensor& b);
  DeviceTensor resample(const DeviceTensor& x, bool up);  // [B, C, X, Y, Z]: nearest 2x up or 2x average pooling
  DeviceTensor geglu(const DeviceTensor& x);              // [B, 2C, tokens] -> [B, C, tokens]
  DeviceTensor concat(const DeviceTensor& a, const DeviceTensor& b);  // along channels (transfer copies)
  // 2-D layers of [B, C, H, W] maps (the GSM's image networks).
  // Conv2d with the weight [Co, Ci, kh, kw] at `prefix.weight` (+ `prefix.bias` when present).
  DeviceTensor conv2d(const DeviceTensor& x, const std::string& prefix, uint32_t stride, uint32_t padding);
  // y = act(x * scale[c] + shift[c]) with the vectors at `scale` and `shift` (a folded inference BatchNorm,
  // a normalisation by a fixed mean and std, a layer scale).
  DeviceTensor channel_affine(const DeviceTensor& x, const std::string& scale, const std::string& shift,
                              kernels::nn::BatchNormActivation act);
  // F.interpolate to (out_h, out_w) by mode (align_corners for bilinear and bicubic).
  DeviceTensor interpolate(const DeviceTensor& x, int64_t out_h, int64_t out_w, kernels::nn::InterpolateMode mode,
                           bool align_corners);
  DeviceTensor gelu(const DeviceTensor& x);
  DeviceTensor relu(const DeviceTensor& x);

  // Multi-head attention of [B, C, tokens]: q, k, v separate or one [B, 3C, tokens] (q, k, v channel thirds).
  DeviceTensor attention(const DeviceTensor& q, const DeviceTensor& k, const DeviceTensor& v, uint32_t heads);
  DeviceTensor attention_qkv(const DeviceTensor& qkv, uint32_t heads);
  static DeviceTensor tokens(const DeviceTensor& x);  // the same buffer viewed as [B, C, spatial]

  // Tests: the windowed kernels window as if one binding held at most `bytes` (0 = the device's limit).
  void set_max_binding_bytes(uint64_t bytes);
  // Multiply-add FLOPs (2 per product) of the dense convolutions, linears and attention recorded since the
  // last reset: a network's useful work, for rates and fractions of a device's peak (benchmarks). Padding
  // taps count as PyTorch's profilers count them; norms and element-wise layers are not counted.
  uint64_t matmul_flops() const { return matmul_flops_; }
  void reset_matmul_flops() { matmul_flops_ = 0; }

 private:
  gpu::Context& ctx_;
  const ParameterStore& params_;
  ActivationPool pool_;
  gpu::CommandList* cmd_ = nullptr;
  bool f16_conv_operands_ = false;
  uint64_t matmul_flops_ = 0;
  std::unique_ptr<kernels::nn::Conv3d> conv_;
  std::unique_ptr<kernels::nn::Conv2d> conv2d_;
  std::unique_ptr<kernels::nn::BatchNorm> channel_affine_;
  std::unique_ptr<kernels::nn::Interpolate> interpolate_;
  std::unique_ptr<kernels::nn::SparseConv3d> sparse_conv_;
  std::unique_ptr<kernels::nn::GroupNorm> group_norm_;
  std::unique_ptr<kernels::nn::LayerNorm> layer_norm_;
  std::unique_ptr<kernels::nn::Elementwise> elementwise_;
  std::unique_ptr<kernels::nn::Resample> resample_;
  std::unique_ptr<kernels::nn::Attention> attention_;
};

}  // namespace icube::nn
