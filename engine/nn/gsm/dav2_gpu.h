// The GSM's Depth-Anything-V2 image features on the GPU: the computation of
// dav2_reference.h through the LayerRecorder. Bilinear resize and ImageNet
// normalisation (channel_affine), the 14x14 patch embedding (conv2d, stride =
// patch), tokens kept channel-major [V, C, 1 + h*w] with the CLS token first
// (assembled and, for the neck, dropped again with transfer copies of channel
// rows), the bicubically resized position grid (computed once per patch grid
// when a Dav2PositionEmbeddings cache is given), pre-norm transformer layers
// (layer_norm over channels, linears as 1x1 convs, multi-head attention,
// layer scale as a channel_affine with a zero shift, exact GELU), the final
// LayerNorm, the DPT neck (1x1 projection, conv_transpose2d for factors > 1,
// a 3x3 strided conv for 1/k), its 3x3 convs, the fusion stage and the
// upsampler's residual blocks (folded BatchNorm + SiLU, nearest x2).
// Test: tests/nn/test_gsm_dav2_gpu.cpp (every enc.dav2.* of gsm_small, the CPU
// reference on one and two views).
#pragma once

#include "nn/gsm/gsm_trace.h"

#include "kernels/nn/cpu_tensor.h"
#include "nn/device_tensor.h"
#include "nn/gsm/dav2_reference.h"
#include "nn/gsm/gsm_weights.h"
#include "nn/layer_recorder.h"

#include <cstdint>
#include <map>
#include <string>
#include <utility>

namespace icube::nn {

// Throws scene::InputError naming the key of a setting the GPU stage does not implement: the SwiGLU MLP,
// upsampler blocks with 2x2 average pooling or GroupNorm (none of them in the released model).
void check_dav2_gpu(const Dav2Config& cfg, const std::string& source);

// The Depth-Anything tensors the GPU stage reads in another form than the state dict, added to `out`
// when the weights hold the Depth-Anything backbone (called by gsm_gpu_weights):
//   img_encoder.encoders.dav2.pixel_scale, .pixel_shift          [3]  1 / std, -mean / std (ImageNet)
//   <model>backbone.embeddings.cls_token_vector                   [C]  the CLS token
//   <model>backbone.embeddings.position_cls_vector                [C]  the CLS entry of the position embeddings
//   <model>backbone.embeddings.position_grid_channels             [C * G * G]  the position grid, channel-major
//   <model>backbone.layer_scale_shift                             [C]  zeros: the layer scales' channel-affine shift
//   <model>neck.reassemble_stage.layers.<k>.resize.transposed_weight  every 4-D resize weight [Ci, Co, k, k]
//        packed for kernels/nn/conv_transpose2d.h (only the up-projections read it)
// and takes out the rank-3 tables cls_token [1, 1, C] and position_embeddings [1, 1 + G^2, C], which the
// ParameterStore would pack as matrices (the vectors above replace them).
// (<model> = img_encoder.encoders.dav2.model.) Throws std::invalid_argument on a malformed position table.
void add_dav2_gpu_tensors(const GsmWeights& w, std::map<std::string, CpuTensor>& out);

// What the GPU stage recorded, under the reference's names (enc.dav2.pixel_values, pos_embed_interp,
// embeddings, layer.<i>, feature_maps.<k>, reassemble.<k>, neck_conv.<k>, fusion.<k>, upsampler.<j>,
// out). Token tensors are channel-major: pos_embed_interp [1, C, T], embeddings / layer / feature_maps
// [V, C, T] (the reference's are [V, T, C]); out is [V, C_out, h, w] (the reference's [B, N, ...]).
struct Dav2GpuTrace {
  std::map<std::string, DeviceTensor> tensors;
};

// The interpolated position embeddings [1, C, 1 + gh*gw] per patch grid, made on the first forward at
// that grid and kept in buffers of their own (released through the context's retire list, so the cache
// may go while recorded work is pending). They depend only on the weights and the grid: one cache per
// ParameterStore.
class Dav2PositionEmbeddings {
 public:
  const DeviceTensor& get(LayerRecorder& L, const Dav2Config& cfg, int64_t grid_h, int64_t grid_w);
  size_t size() const { return grids_.size(); }

 private:
  std::map<std::pair<int64_t, int64_t>, DeviceTensor> grids_;
};

// After the recording ran: the trace in the reference's names and layouts (tokens [V, T, C],
// pos_embed_interp [1, T, C], out [batch, V / batch, C_out, h, w]).
GsmTrace download_dav2_trace(gpu::Context& ctx, const Dav2GpuTrace& trace, int64_t batch);

// images [V, 3, H, W] RGB in [0, 1] -> [V, C_out, h, w], recorded on L (between L.begin and L.end).
// Without `positions` the position embeddings are interpolated in this recording (pooled).
DeviceTensor dav2_gpu(LayerRecorder& L, const Dav2Config& cfg, const DeviceTensor& images, Dav2GpuTrace* trace = nullptr,
                      Dav2PositionEmbeddings* positions = nullptr);

}  // namespace icube::nn
