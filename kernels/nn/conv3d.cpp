// Dense conv3d host module; see conv3d.h.
#include "kernels/nn/conv3d.h"

#include "gpu/context.h"
#include "kernels/nn/buffer_checks.h"
#include "kernels/nn/float16.h"
#include "kernels/nn/kernel_family.h"
#include "shared/nn_params.h"

#include <algorithm>
#include <numeric>
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

std::vector<uint16_t> pack_conv3d_weights_f16(const std::vector<float>& w, uint32_t co, uint32_t ci, uint32_t k) {
  const std::vector<float> packed = pack_conv3d_weights(w, co, ci, k);
  std::vector<uint16_t> out(packed.size());
  for (size_t i = 0; i < packed.size(); ++i) out[i] = icube::nn::float_to_half(packed[i]);
  return out;
}

const char* conv3d_path_name(Conv3dPath path) {
  switch (path) {
    case Conv3dPath::kRegisterTile: return "register";
    case Conv3dPath::kSharedTile: return "tiled";
    case Conv3dPath::kCoopMatrix: return "coopmat";
    case Conv3dPath::kCoopMatrixEmulated: return "emulated";
  }
  return "?";
}

std::string conv3d_path_unavailable(Conv3dPath path, const gpu::DeviceInfo& device) {
  if (path == Conv3dPath::kCoopMatrix && !(device.cooperative_matrix_nv && device.subgroup_size == 32))
    return "the device has no VK_NV_cooperative_matrix with fp16 16x16x16 fragments and subgroups of 32";
  if (path == Conv3dPath::kCoopMatrixEmulated && !device.shader_float16)
    return "the device has no shaderFloat16 (fp16 shared tiles)";
  return "";
}

bool conv3d_path_rounds_activations(Conv3dPath path) {
  return path == Conv3dPath::kCoopMatrix || path == Conv3dPath::kCoopMatrixEmulated;
}

Conv3dPath default_conv3d_path(const gpu::DeviceInfo& device, bool f16_weights) {
  if (kernel_family(device) == KernelFamily::kLavapipe) return Conv3dPath::kRegisterTile;
  if (f16_weights && conv3d_path_unavailable(Conv3dPath::kCoopMatrix, device).empty()) return Conv3dPath::kCoopMatrix;
  return Conv3dPath::kSharedTile;
}

Conv3d::Conv3d(gpu::Context& ctx) : ctx_(ctx) {
  // Create the default paths' programs now, so pipeline creation does not land inside a timed forward.
  for (const bool f16 : {false, true})
    for (const uint32_t k : {3u, 1u}) program(path(f16), k, f16);
}

Conv3dPath Conv3d::path(bool f16_weights) const {
  return forced_path_ ? *forced_path_ : default_conv3d_path(ctx_.info(), f16_weights);
}

const char* Conv3d::shader_name(Conv3dPath path, bool f16_weights) {
  static const char* const kNames[4][2] = {{"nn/conv3d", "nn/conv3d_f16w"},
                                           {"nn/conv3d_tiled", "nn/conv3d_tiled_f16w"},
                                           {"nn/conv3d_coopmat", "nn/conv3d_coopmat_f16w"},
                                           {"nn/conv3d_coopmat_emulated", "nn/conv3d_coopmat_emulated_f16w"}};
  return kNames[static_cast<int>(path)][f16_weights ? 1 : 0];
}

gpu::Program& Conv3d::program(Conv3dPath path, uint32_t kernel, bool f16_weights) {
  if (const std::string why = conv3d_path_unavailable(path, ctx_.info()); !why.empty())
    throw std::invalid_argument(std::string("conv3d: the ") + conv3d_path_name(path) + " path: " + why);
  return ctx_.program(shader_name(path, f16_weights), gpu::SpecConstants{}.set(0, kernel /* NN_K */));
}

void Conv3d::record(gpu::CommandList& cmd, const Conv3dShape& s, const gpu::Buffer& x, const gpu::Buffer& w,
                    const gpu::Buffer* bias, const gpu::Buffer& y) {
  if (s.kernel != 1 && s.kernel != 3) throw std::invalid_argument("conv3d: kernel " + std::to_string(s.kernel) + " (1 or 3)");
  if (s.batch == 0 || s.in_channels == 0 || s.out_channels == 0 || s.voxels() == 0) return;
  const uint64_t S = s.voxels();
  const uint64_t limit = max_binding_bytes_ ? max_binding_bytes_ : ctx_.info().max_storage_buffer_range;
  const uint64_t x_element = s.f16_input ? 2 : 4;
  const uint64_t x_bytes = uint64_t{s.batch} * s.in_channels * S * x_element, y_bytes = uint64_t{s.batch} * s.out_channels * S * 4;
  const uint64_t co_vec4s = gpu::div_up(s.out_channels, NN_CONV_CO_TILE) * (NN_CONV_CO_TILE / 4);
  const uint64_t w_bytes = uint64_t{s.in_channels} * s.kernel * s.kernel * s.kernel * co_vec4s * (s.f16_weights ? 8 : 16);
  require_buffer("conv3d", "input", x_bytes, x);
  require_buffer("conv3d", "output", y_bytes, y);
  require_buffer("conv3d", "packed weights", w_bytes, w);
  if (bias) require_buffer("conv3d", "bias", uint64_t{s.out_channels} * 4, *bias);
  // Weights over one binding go in windows of whole input channels (all taps and output columns of
  // each), a multiple of the channels whose rows meet the binding-offset alignment.
  const uint64_t w_row = w_bytes / s.in_channels;
  const bool w_windows = w_bytes > ctx_.info().max_storage_buffer_range;
  uint64_t w_channels = s.in_channels, w_unit = 1;
  if (w_windows) {
    w_unit = gpu::aligned_element_unit(ctx_.info(), w_row);
    w_channels = ctx_.info().max_storage_buffer_range / w_row / w_unit * w_unit;
    if (w_channels == 0)
      throw std::invalid_argument("conv3d: the packed weights of one input channel (" + std::to_string(w_row * w_unit) +
                                  " bytes for " + std::to_string(s.out_channels) +
                                  " output channels) exceed one storage binding; use fewer output channels");
  }
  if (S > UINT32_MAX / 4) throw std::invalid_argument("conv3d: grid of " + std::to_string(S) + " voxels is too large");

  shader::Conv3dParams pc{};
  pc.in_channels = s.in_channels;
  pc.co_vec4s = static_cast<uint32_t>(co_vec4s);
  pc.size_x = s.x;
  pc.size_y = s.y;
  pc.size_z = s.z;
  pc.kernel = s.kernel;
  const Conv3dPath conv_path = path(s.f16_weights);
  gpu::Program& prog = program(conv_path, s.kernel, s.f16_weights);
  // Workgroup shape per path: the register tile covers NN_CONV_GROUP runs of NN_CONV_ZRUN voxels and 8
  // channels; the tiled paths a 64 x 64 block of voxels and channels.
  const bool register_tile = conv_path == Conv3dPath::kRegisterTile;
  const bool coop = conv_path == Conv3dPath::kCoopMatrix || conv_path == Conv3dPath::kCoopMatrixEmulated;
  const uint32_t group_size = register_tile ? NN_CONV_GROUP : coop ? NN_CONV_COOP_GROUP : NN_CONV_TILED_GROUP;
  const uint32_t co_block = register_tile ? NN_CONV_CO_TILE : coop ? NN_CONV_COOP_BN : NN_CONV_TILED_BN;
  static_assert(NN_CONV_TILED_BM == NN_CONV_COOP_BM, "one voxel tile for both tiled paths");
  pc.voxel_tiles = static_cast<uint32_t>(
      register_tile ? gpu::div_up(uint64_t{s.x} * s.y * gpu::div_up(s.z, NN_CONV_ZRUN), NN_CONV_GROUP)
                    : gpu::div_up(S, NN_CONV_TILED_BM));
  pc.has_bias = bias ? 1u : 0u;
  gpu::BufferBinding wb = w_windows ? gpu::null_binding() : w.binding(0, w_bytes);
  const gpu::BufferBinding bb = bias ? bias->binding(0, uint64_t{s.out_channels} * 4) : gpu::null_binding();
  auto dispatch = [&](uint32_t batch, const gpu::BufferBinding& xb, const gpu::BufferBinding& yb) {
    pc.batch = batch;
    pc.co_blocks = static_cast<uint32_t>(gpu::div_up(pc.co_count, co_block));
    const uint64_t groups = uint64_t{pc.voxel_tiles} * pc.co_blocks * batch;
    cmd.dispatch(prog, gpu::Threads{groups * group_size}, pc, {xb, wb, bb, yb});
  };
  // An invocation of the register tile makes about ci_count * (1 + k + k^2) loop iterations (the z-taps
  // unroll), the shared tile ci_count * k^3 / 16; lavapipe stops one after 65,535, so input channels go in
  // windows of at most kMaxChannelsPerDispatch. The emulated fragments loop ~1,100 times per K step of 32.
  const uint64_t kMaxChannelsPerDispatch = conv_path == Conv3dPath::kCoopMatrixEmulated ? 48 : 4096;
  const uint64_t texel_limit = ctx_.info().max_texel_buffer_elements * x_element;
  if (!w_windows && x_bytes <= std::min(limit, texel_limit) && y_bytes <= limit &&
      s.in_channels <= kMaxChannelsPerDispatch) {
    // One dispatch for everything.
    pc.co_begin = 0;
    pc.co_count = s.out_channels;
    pc.ci_begin = 0;
    pc.ci_count = s.in_channels;
    pc.accumulate = 0;
    pc.x_offset = pc.y_offset = 0;
    pc.x_batch_stride = static_cast<uint32_t>(s.in_channels * S);
    pc.y_batch_stride = static_cast<uint32_t>(s.out_channels * S);
    dispatch(s.batch, texel_window(ctx_, x, 0, x_bytes / x_element, x_element).binding, y.binding(0, y_bytes));
    return;
  }
  // Windows: one batch element at a time, output channels in whole 8-channel
  // blocks, input channels as many as fit; each window bound at its offset
  // aligned down (element_window; the rest goes to *_offset), so a window holds
  // one alignment less than a binding (window_elements).
  const uint64_t usable = window_elements(ctx_, max_binding_bytes_);
  const uint64_t ci_window = std::min({usable / S, kMaxChannelsPerDispatch, w_channels}) / w_unit * w_unit;
  const uint64_t co_window = usable / S / NN_CONV_CO_TILE * NN_CONV_CO_TILE;
  if (ci_window == 0 || co_window == 0)
    throw std::invalid_argument("conv3d: " + std::to_string(NN_CONV_CO_TILE) + " channels of " + std::to_string(S) +
                                " voxels exceed one storage binding (" + std::to_string(limit) + " bytes)");
  auto window = [&](const gpu::Buffer& buf, uint64_t first_element, uint64_t elements, uint32_t& offset, bool texel) {
    const ElementWindow ew = texel ? texel_window(ctx_, buf, first_element, elements, x_element)
                                   : element_window(ctx_, buf, first_element, elements);
    offset = ew.offset;
    return ew.binding;
  };
  pc.x_batch_stride = pc.y_batch_stride = 0;  // one batch element per dispatch
  for (uint32_t b = 0; b < s.batch; ++b)
    for (uint64_t co0 = 0; co0 < s.out_channels; co0 += co_window) {
      pc.co_begin = static_cast<uint32_t>(co0);
      pc.co_count = static_cast<uint32_t>(std::min<uint64_t>(co_window, s.out_channels - co0));
      const gpu::BufferBinding yb = window(y, (uint64_t{b} * s.out_channels + co0) * S, uint64_t{pc.co_count} * S, pc.y_offset, false);
      for (uint64_t ci0 = 0; ci0 < s.in_channels; ci0 += ci_window) {
        pc.ci_begin = static_cast<uint32_t>(ci0);
        pc.ci_count = static_cast<uint32_t>(std::min<uint64_t>(ci_window, s.in_channels - ci0));
        pc.accumulate = ci0 > 0 ? 1u : 0u;
        // Later input windows read-modify-write the same y window.
        if (ci0 > 0) cmd.barrier(gpu::deps::kComputeToCompute);
        const gpu::BufferBinding xb = window(x, (uint64_t{b} * s.in_channels + ci0) * S, uint64_t{pc.ci_count} * S, pc.x_offset, true);
        if (w_windows) {
          pc.w_ci_base = pc.ci_begin;
          wb = w.binding(ci0 * w_row, uint64_t{pc.ci_count} * w_row);
        }
        dispatch(1, xb, yb);
      }
    }
}

}  // namespace icube::kernels::nn
