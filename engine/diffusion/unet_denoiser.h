// The diffusion UNet on the GPU as the sampler's Denoiser: one batched
// forward per call, every batch element at the same timestep; on the device
// path the input and the prediction stay in device buffers.
#pragma once

#include "diffusion/chunk_sampler.h"
#include "nn/unet_gpu.h"

#include <vector>

namespace icube::diffusion {

class UNetDenoiser final : public Denoiser {
 public:
  explicit UNetDenoiser(nn::UNetGpu& net) : net_(net) {}
  nn::CpuTensor predict(const nn::CpuTensor& x_in, int t) override {
    return net_.forward(x_in, std::vector<int64_t>(static_cast<size_t>(x_in.shape[0]), t));
  }
  void predict_on_device(gpu::Context&, const gpu::Buffer& x_in, const std::vector<int64_t>& x_shape, int t, const gpu::Buffer& v) override {
    net_.forward(x_in, x_shape, std::vector<int64_t>(static_cast<size_t>(x_shape[0]), t), v);
  }

 private:
  nn::UNetGpu& net_;
};

}  // namespace icube::diffusion
