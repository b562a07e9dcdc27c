// The GSM pixel branch's U-Net, lucidrains' x-unet XUnet 0.4.0 (x_unet/x_unet.py)
// as a plain CPU reference, for images (frame kernel 1: every 3-D conv of the
// official model has a frame kernel of 1, weight (out, in, 1, k, k), and runs
// as a 2-D conv here). Structure:
//   init_conv 7x7 -> per stage s: ResnetBlock x num_blocks[s] (the first is
//   downs.s.0, the others downs.s.1.j), keep the map as the skip, Downsample
//   (2x2 space-to-depth, channel = c*4 + dy*2 + dx, then a 1x1 conv);
//   mid ResnetBlock, mid_attn (pre-LayerNorm multi-head attention over all
//   pixels that adds its own residual; XUnet adds its input once more, so
//   x <- attn(x) + 2x), mid_after, mid_upsample (ConvTranspose 4x4, stride 2,
//   padding 1); per up stage: concat [x, skip * skip_scale], ResnetBlocks,
//   ConvTranspose upsample (every up stage upsamples: XUnet's is_last is
//   never true for them; the finest down stage's skip is left unused);
//   consolidator: each up stage's and the mid block's map (before its
//   upsample) through a ResnetBlock to `dim` channels, resized (nearest) to
//   full size and concatenated after x; concat the init_conv output; final
//   ResnetBlock + 3x3 conv to out_dim.
// ResnetBlock: h = Block(Block(x)) + res_conv(x) (1x1 conv when the width
// changes); Block = 3x3 conv (weight-standardised if configured, eps 1e-5)
// -> RMSNorm over channels (x / max(|x|_2, 1e-12) * sqrt(C) * gamma) -> SiLU.
// The attention's LayerNorm: over channels, biased variance, eps 1e-5, gamma
// only; heads attn_heads[-1], head width attn_dim_head[-1], no qkv/out bias.
// Unsupported XUnet options (self-attention blocks inside stages, ConvNeXt
// blocks, nested U-Nets, frame kernels > 1) throw std::invalid_argument.
// Test: tests/nn/test_gsm_pixel_branch_reference.cpp (every pix.unet.* of gsm_small).
#pragma once

#include "kernels/nn/cpu_tensor.h"
#include "nn/gsm/gsm_trace.h"
#include "nn/gsm/gsm_weights.h"

#include <nlohmann/json_fwd.hpp>

#include <string>
#include <vector>

namespace icube::nn {

struct XUnetConfig {
  int channels = 3;  // input channels
  int dim = 0;
  int init_dim = 0;  // init_conv's width (default dim)
  int out_dim = 0;   // default channels
  std::vector<int> dim_mults;                // stage widths dim * m
  std::vector<int> num_blocks_per_stage;     // ResnetBlocks per stage (>= 1)
  std::vector<int> num_self_attn_per_stage;  // must be all 0 (the GSM's)
  std::vector<int> attn_heads;               // per stage; the mid attention uses the last
  std::vector<int> attn_dim_head;            // per stage; the mid attention uses the last
  bool consolidate_upsample_fmaps = true;
  bool weight_standardize = false;
  double skip_scale = 0.70710678118654752440;  // 2^-0.5

  int stages() const { return static_cast<int>(dim_mults.size()); }
};

// From the `unet2d_params` object (hparams.backbone.params.backbone_2d_params.unet2d_params), with
// XUnet's defaults for absent keys; a per-stage value may be one integer or a list of one per stage.
// Throws scene::InputError for a malformed value and std::invalid_argument for an unsupported option.
XUnetConfig xunet_config_from_json(const nlohmann::json& unet2d_params);

// x [V, channels, H, W] (H, W multiples of 2^stages) -> [V, out_dim, H, W]. Weights under `prefix`
// (e.g. "backbone.backbone_2d.net."). The trace gets <trace_prefix>init_conv, downs.<s>.0,
// downs.<s>.1.<j>, downs.<s>.3, mid, mid_attn (the attention module's output, its own residual
// included), mid_after, mid_upsample, ups.<s>.0, ups.<s>.1.<j>, ups.<s>.3 and consolidator, each
// as [V, C, 1, h, w] like the official 1-frame video tensors.
CpuTensor xunet_forward(const XUnetConfig& config, const GsmWeights& weights, const std::string& prefix, const CpuTensor& x,
                        GsmTrace* trace, const std::string& trace_prefix = "pix.unet.");

}  // namespace icube::nn
