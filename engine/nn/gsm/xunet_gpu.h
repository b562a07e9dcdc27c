// The GSM pixel branch's U-Net (x-unet XUnet 0.4.0, frame kernel 1) on the GPU:
// the computation of xunet_reference.h through the LayerRecorder —
//   convolutions      conv2d on the squeezed (out, in, kh, kw) weights, "same" padding
//   Block             conv 3x3 -> RMSNorm over channels fused with SiLU (kernels/nn/rms_norm.h, in place)
//   ResnetBlock       Block(Block(x)) + (1x1 res_conv(x) or x)
//   Downsample        space-to-depth (channel c * 4 + dy * 2 + dx) then a 1x1 conv, run as the
//                     equal 2x2 stride-2 conv2d (weight [o, c, dy, dx] = w1x1[o, c * 4 + dy * 2 + dx])
//   Upsample          ConvTranspose 4x4, stride 2, padding 1 (kernels/nn/conv_transpose2d.h)
//   mid attention     LayerNorm over channels (eps 1e-5, gamma only: a zero bias), 1x1 qkv, multi-head
//                     attention (attn_heads[-1] heads of attn_dim_head[-1]), 1x1 out, + its input; the
//                     XUnet then adds its input once more
//   skip              the down stage's map times skip_scale (a channel affine), concatenated after x
//   consolidator      each up stage's map and the mid map resized (nearest) to full size, a ResnetBlock
//                     each, concatenated after x; then [x, init_conv output] -> ResnetBlock -> 3x3 conv
// The weights in the GSM's GPU store (gsm_gpu_weights.h) take the forms add_xunet_gpu_tensors gives them.
// Test: tests/nn/test_gsm_pixel_branch_gpu.cpp (every pix.unet.* of gsm_small; two views against the
// CPU reference).
#pragma once

#include "kernels/nn/cpu_tensor.h"
#include "nn/device_tensor.h"
#include "nn/gsm/gsm_weights.h"
#include "nn/gsm/xunet_reference.h"
#include "nn/layer_recorder.h"

#include <map>
#include <string>

namespace icube::nn {

// Throws scene::InputError (naming `source`) for an x-unet setting the GPU stage does not implement:
// weight standardisation (the released model has none; its weights would need the configuration).
void check_xunet_gpu(const XUnetConfig& c, const std::string& source);

// The x-unet weights under `prefix` (default the GSM pixel branch's) in the forms the GPU stage reads,
// written into `out` (called by gsm_gpu_weights):
//   <conv>.weight                 every frame-kernel-1 conv weight (out, in, 1, kh, kw) squeezed to
//                                 (out, in, kh, kw) under its own name (ParameterStore cannot pack the 5-D
//                                 form; the transposed convs' (in, out, 1, 4, 4) likewise)
//   <upsample>.transposed_weight  mid_upsample and ups.<u>.3: packed for kernels/nn/conv_transpose2d.h
//   <downsample>.space_to_depth_weight  downs.<s>.3.1: the 2x2 stride-2 form [out, in / 4, 2, 2]
//   <norm>.weight                 every RMSNorm / LayerNorm gamma as a vector [C]
//   <norm>.bias                   zeros [C] for the LayerNorm (gamma (1, C, 1, 1, 1)), which has no bias
// Throws std::invalid_argument for a 5-D weight with a frame kernel other than 1.
void add_xunet_gpu_tensors(const GsmWeights& w, std::map<std::string, CpuTensor>& out,
                           const std::string& prefix = "backbone.backbone_2d.net.");

// x [V, channels, H, W] (H, W multiples of 2^stages) -> [V, out_dim, H, W], recorded on L (between L.begin
// and L.end). `trace` (not null) receives every block the reference traces as <trace_prefix><block>
// (init_conv, downs.<s>.0, downs.<s>.1.<j>, downs.<s>.3, mid, mid_attn, mid_after, mid_upsample, ups.<u>.0,
// ups.<u>.1.<j>, ups.<u>.3, consolidator) as [V, C, h, w] (the reference's are [V, C, 1, h, w]).
DeviceTensor xunet_gpu(LayerRecorder& L, const XUnetConfig& c, const std::string& prefix, const DeviceTensor& x,
                       std::map<std::string, DeviceTensor>* trace = nullptr, const std::string& trace_prefix = "pix.unet.");

}  // namespace icube::nn
