// Dense conv3d host module; see conv3d.h.
#include "nn/conv3d.h"

#include "gpu/context.h"
#include "shared/nn_params.h"

#include <stdexcept>
#include <string>

namespace icube::kernels::nn {

uint64_t Conv3dShape::flops() const {
  return 2ull * batch * out_channels * in_channels * kernel * kernel * kernel * voxels();
}

std::vector<float> pack_conv3d_weights(const std::vector<float>& w, uint32_t co, uint32_t ci, uint32_t k) {
  const uint64_t taps = uint64_t{k} * k * k, co_pad = gpu::align_up(co, NN_CONV_CO_TILE);
  if (w.size() != uint64_t{co} * ci * taps)
    throw std::invalid_argument("conv3d: " + std::to_string(w.size()) + " weights for [" + std::to_string(co) + ", " +
                                std::to_string(ci) + ", " + std::to_string(k) + "^3]");
  std::vector<float> out(static_cast<size_t>(ci * taps * co_pad), 0.0f);
  for (uint64_t o = 0; o < co; ++o)
    for (uint64_t i = 0; i < ci; ++i)
      for (uint64_t t = 0; t < taps; ++t) out[static_cast<size_t>((i * taps + t) * co_pad + o)] = w[static_cast<size_t>((o * ci + i) * taps + t)];
  return out;
}

Conv3d::Conv3d(gpu::Context& ctx) : ctx_(ctx), program_(ctx.program("nn/conv3d")) {}

void Conv3d::record(gpu::CommandList& cmd, const Conv3dShape& s, const gpu::Buffer& x, const gpu::Buffer& w,
                    const gpu::Buffer* bias, const gpu::Buffer& y) {
  if (s.kernel != 1 && s.kernel != 3) throw std::invalid_argument("conv3d: kernel " + std::to_string(s.kernel) + " (1 or 3)");
  if (s.batch == 0 || s.in_channels == 0 || s.out_channels == 0 || s.voxels() == 0) return;
  const uint64_t limit = ctx_.info().max_storage_buffer_range;
  const uint64_t x_bytes = uint64_t{s.batch} * s.in_channels * s.voxels() * 4,
                 y_bytes = uint64_t{s.batch} * s.out_channels * s.voxels() * 4;
  const uint64_t co_blocks = gpu::div_up(s.out_channels, NN_CONV_CO_TILE);
  const uint64_t w_bytes = uint64_t{s.in_channels} * s.kernel * s.kernel * s.kernel * co_blocks * NN_CONV_CO_TILE * 4;
  auto check = [&](const char* what, uint64_t need, const gpu::Buffer& b) {
    if (need > limit)
      throw std::invalid_argument(std::string("conv3d: ") + what + " of " + std::to_string(need) +
                                  " bytes exceeds one storage binding (" + std::to_string(limit) + ")");
    if (need > b.size())
      throw std::invalid_argument(std::string("conv3d: ") + what + " buffer holds " + std::to_string(b.size()) +
                                  " bytes, needs " + std::to_string(need));
  };
  check("input", x_bytes, x);
  check("output", y_bytes, y);
  check("packed weights", w_bytes, w);
  if (bias) check("bias", uint64_t{s.out_channels} * 4, *bias);
  if (uint64_t{s.batch} * s.out_channels * s.voxels() > UINT32_MAX || uint64_t{s.batch} * s.in_channels * s.voxels() > UINT32_MAX)
    throw std::invalid_argument("conv3d: tensor exceeds 2^32 elements");
  shader::Conv3dParams pc{};
  pc.batch = s.batch;
  pc.in_channels = s.in_channels;
  pc.out_channels = s.out_channels;
  pc.co_blocks = static_cast<uint32_t>(co_blocks);
  pc.size_x = s.x;
  pc.size_y = s.y;
  pc.size_z = s.z;
  pc.kernel = s.kernel;
  pc.voxel_tiles = static_cast<uint32_t>(gpu::div_up(s.voxels(), NN_CONV_GROUP * NN_CONV_VOXELS));
  pc.has_bias = bias ? 1u : 0u;
  const uint64_t groups = uint64_t{pc.voxel_tiles} * co_blocks * s.batch;
  cmd.dispatch(program_, gpu::Threads{groups * NN_CONV_GROUP}, pc,
               {x.binding(0, x_bytes), w.binding(0, w_bytes), bias ? bias->binding(0, uint64_t{s.out_channels} * 4) : gpu::null_binding(),
                y.binding(0, y_bytes)});
}

}  // namespace icube::kernels::nn
