// The GSM's sky (InfiniCube SkyboxMlpModulator, gsm_small README steps 4 and
// 7) as a plain CPU reference:
//   sky token   a patch-size conv embeds the [0, 1] image; a patch is used when more than 75 % of its
//               pixels are sky (mask ch0 == 0); each patch's ray (intrinsics divided by the patch grid, so
//               through the patch's top-left pixel; rotation only) in OpenGL axes (x, y, z) -> (-y, z, -x),
//               normalised, through a linear layer, is added to its token; the learned query goes in
//               front of the used patches of all views of a batch element; a post-norm GELU transformer
//               encoder runs; its first token is the sky token.
//   sky colour  for a unit direction (OpenGL axes): pos_emb linear, LayerNorm without affine (eps 1e-6),
//               x (1 + scale) + shift with (shift, scale) = adaLN(SiLU(condition_mapping(token))), and an
//               output linear (raw RGB).
// Weights `skybox.*`. Traced: sky.patch_embed, sky.valid_patch_mask, sky.pos_embed.in, sky.pos_embed,
// sky.tokens_in.b<i>, sky.tokens_out.b<i>. Tests: tests/nn/test_gsm_reference.cpp.
#pragma once

#include "kernels/nn/cpu_tensor.h"
#include "nn/gsm/gsm_inputs.h"
#include "nn/gsm/gsm_trace.h"
#include "nn/gsm/gsm_weights.h"

#include <nlohmann/json_fwd.hpp>

#include <array>
#include <cstdint>
#include <vector>

namespace icube::nn {

struct SkyConfig {
  int patch_size = 16;
  int embed_dim = 0, hidden_channels = 0, out_channels = 3, heads = 0;
  int layers = 0, feed_forward = 0;
  bool model_midground = true;  // sky = pure sky (mask ch0 == 0); else also pixels off the grid foreground
};

// From config.json's hparams (skybox_mlp_modulator: sky_token_encoding_type "transformer", embedders "mlp",
// feature source "original_rgb", GELU; anything else is refused with its key named).
SkyConfig sky_config_from_json(const nlohmann::json& hparams);

// The sky token [B, embed_dim] of every batch element (images [B * N, 3, H, W]): the patch embedding,
// sky_token_inputs, sky_encoder, the first token. The GPU route: sky_token_gpu.h.
CpuTensor sky_tokens(const SkyConfig& c, const GsmWeights& w, const GsmInputs& in, const CpuTensor& images, GsmTrace* trace);

// From the patch embedding [B * N, embed_dim, H / patch, W / patch]: each element's encoder input
// [1 + used patches, embed_dim] (the query, then every used patch's embedding plus its ray embedding,
// views then patches in order). Traces sky.patch_embed, sky.valid_patch_mask, sky.pos_embed.in,
// sky.pos_embed and sky.tokens_in.b<i>.
struct SkyTokenInputs {
  std::vector<CpuTensor> tokens_in;  // [B] of [count_b, embed_dim]
};
SkyTokenInputs sky_token_inputs(const SkyConfig& c, const GsmWeights& w, const GsmInputs& in, const CpuTensor& patches,
                                GsmTrace* trace);
// The post-norm transformer encoder on tokens [n, embed_dim].
CpuTensor sky_encoder(const SkyConfig& c, const GsmWeights& w, CpuTensor x);

// The modulator's adaLN vectors under one sky token [embed_dim]: [2 hidden_channels], shift then scale
// (adaLN_modulation(silu(condition_mapping(token)))).
std::vector<float> sky_modulation(const SkyConfig& c, const GsmWeights& w, const float* token);

// Sky colours [n, out_channels] for unit directions [n, 3] (OpenGL axes) under one sky token [embed_dim].
CpuTensor sky_colors(const SkyConfig& c, const GsmWeights& w, const float* token, const CpuTensor& directions);

// The unit direction (OpenGL axes, grid frame) of pixel (col, row) of a camera: ((col - cx) / fx,
// (row - cy) / fy, 1) rotated by the pose, as the official rays are built.
std::array<double, 3> sky_pixel_direction(const std::array<float, 16>& pose, const std::array<float, 6>& intrinsics,
                                          double col, double row);

// The directions sky_image evaluates: every pixel of every view of every element, [B * N * H * W, 3].
CpuTensor sky_image_directions(const GsmInputs& in);
// The directions sky_panorama evaluates: [rows * 2 rows, 3].
CpuTensor sky_panorama_directions(int64_t rows);

// The sky colour of every pixel of every view: [B, N, H, W, out_channels].
CpuTensor sky_image(const SkyConfig& c, const GsmWeights& w, const GsmInputs& in, const CpuTensor& tokens);

// The sky on a latitude-longitude panorama of rows x 2 rows pixel centres: [B, rows, 2 rows, out_channels].
CpuTensor sky_panorama(const SkyConfig& c, const GsmWeights& w, const CpuTensor& tokens, int64_t rows);

}  // namespace icube::nn
