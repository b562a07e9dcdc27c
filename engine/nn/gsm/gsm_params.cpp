// The GSM's state dict from its configuration; see gsm_params.h. Module by module in the official
// registration order (gsm.py Model: img_encoder, skybox, backbone), with the shapes torch gives them.
#include "nn/gsm/gsm_params.h"

#include "nn/gsm/gsm_json.h"
#include "nn/gsm/gsm_preset.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <string>
#include <utility>

namespace icube::nn {

namespace {

using Shape = std::vector<int64_t>;
using Role = GsmTensorRole;

int64_t product(const Shape& s) {
  int64_t n = 1;
  for (const int64_t d : s) n *= d;
  return n;
}

// Appends tensors in order; `run` marks what the forward reads.
struct SpecList {
  std::vector<GsmParamSpec> specs;
  bool run = true;

  void add(std::string name, Shape shape, Role role, int64_t fan_in = 1, int64_t group = 0) {
    GsmParamSpec s;
    s.name = std::move(name);
    s.shape = std::move(shape);
    s.role = role;
    s.fan_in = fan_in;
    s.group = group;
    s.run = run;
    specs.push_back(std::move(s));
  }
  // nn.Linear / nn.ConvNd (and fVDB's k = 1 SparseConv3d, whose weight is [out, in]): weight [out, in, kernel...].
  void conv(const std::string& m, int64_t out, int64_t in, const Shape& kernel = {}, bool bias = true) {
    Shape w{out, in};
    w.insert(w.end(), kernel.begin(), kernel.end());
    const int64_t fan_in = in * product(kernel);
    add(m + ".weight", w, Role::Weight, fan_in);
    if (bias) add(m + ".bias", {out}, Role::Bias, fan_in);
  }
  void linear(const std::string& m, int64_t out, int64_t in, bool bias = true) { conv(m, out, in, {}, bias); }
  // nn.ConvTransposeNd: weight [in, out, kernel...]; torch's fan-in counts the weight's second axis.
  void conv_transpose(const std::string& m, int64_t in, int64_t out, const Shape& kernel) {
    Shape w{in, out};
    w.insert(w.end(), kernel.begin(), kernel.end());
    const int64_t fan_in = out * product(kernel);
    add(m + ".weight", w, Role::Weight, fan_in);
    add(m + ".bias", {out}, Role::Bias, fan_in);
  }
  // GroupNorm / LayerNorm with affine parameters.
  void norm(const std::string& m, int64_t c) {
    add(m + ".weight", {c}, Role::NormWeight);
    add(m + ".bias", {c}, Role::NormBias);
  }
  void batch_norm(const std::string& m, int64_t c) {
    norm(m, c);
    add(m + ".running_mean", {c}, Role::RunningMean);
    add(m + ".running_var", {c}, Role::RunningVar);
    const bool was = run;
    run = false;  // the forward never reads the batch count
    add(m + ".num_batches_tracked", {}, Role::BatchCount);
    run = was;
  }
};

// basic_modules.ResBlock (2-D, use_conv False): in_layers (norm, SiLU, 3x3 conv), out_layers (norm, SiLU,
// dropout, 3x3 conv), a 1x1 skip when the width changes; norm = GroupNorm(32) or BatchNorm2d.
void res_block_2d(SpecList& p, const std::string& m, int64_t in, int64_t out, bool group_norm) {
  auto norm = [&](const std::string& n, int64_t c) { group_norm ? p.norm(n, c) : p.batch_norm(n, c); };
  norm(m + ".in_layers.0", in);
  p.conv(m + ".in_layers.2", out, in, {3, 3});
  norm(m + ".out_layers.0", out);
  p.conv(m + ".out_layers.3", out, out, {3, 3});
  if (in != out) p.conv(m + ".skip_connection", out, in, {1, 1});
}

void conv_encoder(SpecList& p, const ConvEncoderConfig& c) {
  const std::string m = "img_encoder.encoders.conv.project_head.";
  for (size_t i = 0; i + 1 < c.filters.size(); ++i) {
    const int64_t in = c.filters[i], out = c.filters[i + 1], k = c.kernels[i];
    const std::string s = m + std::to_string(i);
    if (c.residual[i]) {
      res_block_2d(p, s, in, out, c.group_norm[i]);
    } else {
      p.conv(s + ".0", out, in, {k, k});
      p.batch_norm(s + ".1", out);
    }
  }
  p.conv(m + "conv_1x1", c.out_dim, c.filters.back(), {1, 1});
}

// transformers' Dinov2Backbone, DepthAnythingNeck and DepthAnythingDepthEstimationHead.
void depth_anything(SpecList& p, const Dav2Config& c, const GsmParamExtras& x) {
  const std::string m = "img_encoder.encoders.dav2.model.";
  const int64_t C = c.hidden_size, P = c.patch_size, F = c.fusion_hidden_size;
  const std::string e = m + "backbone.embeddings.";
  p.add(e + "cls_token", {1, 1, C}, Role::Token);
  if (x.dav2_mask_token) {
    p.run = false;
    p.add(e + "mask_token", {1, C}, Role::Token);
    p.run = true;
  }
  p.add(e + "position_embeddings", {1, c.position_grid * c.position_grid + 1, C}, Role::Token);
  p.conv(e + "patch_embeddings.projection", C, 3, {P, P});
  for (int64_t i = 0; i < c.num_layers; ++i) {
    const std::string l = m + "backbone.encoder.layer." + std::to_string(i) + ".";
    p.norm(l + "norm1", C);
    for (const char* qkv : {"query", "key", "value"}) p.linear(l + "attention.attention." + qkv, C, C, x.dav2_qkv_bias);
    p.linear(l + "attention.output.dense", C, C);
    p.add(l + "layer_scale1.lambda1", {C}, Role::NormWeight);
    p.norm(l + "norm2", C);
    if (c.use_swiglu_ffn) {
      const int64_t hidden = (c.mlp_hidden * 2 / 3 + 7) / 8 * 8;  // Dinov2SwiGLUFFN
      p.linear(l + "mlp.weights_in", 2 * hidden, C);
      p.linear(l + "mlp.weights_out", C, hidden);
    } else {
      p.linear(l + "mlp.fc1", c.mlp_hidden, C);
      p.linear(l + "mlp.fc2", C, c.mlp_hidden);
    }
    p.add(l + "layer_scale2.lambda1", {C}, Role::NormWeight);
  }
  p.run = c.apply_layernorm;
  p.norm(m + "backbone.layernorm", C);
  p.run = true;
  const size_t maps = c.neck_hidden_sizes.size();
  for (size_t k = 0; k < maps; ++k) {
    const std::string r = m + "neck.reassemble_stage.layers." + std::to_string(k) + ".";
    const int64_t N = c.neck_hidden_sizes[k];
    const double f = c.reassemble_factors[k];
    p.conv(r + "projection", N, C, {1, 1});
    if (f > 1.0) p.conv_transpose(r + "resize", N, N, {static_cast<int64_t>(f), static_cast<int64_t>(f)});
    if (f < 1.0) p.conv(r + "resize", N, N, {3, 3});
  }
  for (size_t k = 0; k < maps; ++k) p.conv(m + "neck.convs." + std::to_string(k), F, c.neck_hidden_sizes[k], {3, 3}, false);
  for (size_t k = 0; k < maps; ++k) {
    const std::string f = m + "neck.fusion_stage.layers." + std::to_string(k) + ".";
    p.conv(f + "projection", F, F, {1, 1});
    p.run = k > 0;  // the first (coarsest) fusion layer has no residual input
    p.conv(f + "residual_layer1.convolution1", F, F, {3, 3});
    p.conv(f + "residual_layer1.convolution2", F, F, {3, 3});
    p.run = true;
    p.conv(f + "residual_layer2.convolution1", F, F, {3, 3});
    p.conv(f + "residual_layer2.convolution2", F, F, {3, 3});
  }
  p.run = false;  // the relative-depth head
  p.conv(m + "head.conv1", F / 2, F, {3, 3});
  p.conv(m + "head.conv2", x.dav2_head_hidden_size, F / 2, {3, 3});
  p.conv(m + "head.conv3", 1, x.dav2_head_hidden_size, {1, 1});
  p.run = true;
}

void dav2_upsampler(SpecList& p, const Dav2Config& c) {
  int64_t in = c.fusion_hidden_size;
  for (size_t j = 0; j < c.upsampler.size(); ++j) {
    const Dav2UpsamplerBlock& b = c.upsampler[j];
    res_block_2d(p, "img_encoder.encoders.dav2.upsampler." + std::to_string(j), in, b.out_dim, b.group_norm);
    in = b.out_dim;
  }
}

// SkyboxMlpModulator (transformer token encoding, mlp embedders, RGB input).
void skybox(SpecList& p, const SkyConfig& c) {
  const int64_t E = c.embed_dim, Hd = c.hidden_channels;
  p.add("skybox.sky_query", {1, 1, E}, Role::Query);
  p.linear("skybox.modulator.pos_emb", Hd, 3);
  p.linear("skybox.modulator.adaLN_modulation.1", 2 * Hd, Hd);
  p.linear("skybox.modulator.condition_mapping", Hd, E);
  p.linear("skybox.modulator.output", c.out_channels, Hd);
  p.conv("skybox.patch_embedder", E, 3, {c.patch_size, c.patch_size});
  p.linear("skybox.pos_embedder", E, 3);
  for (int i = 0; i < c.layers; ++i) {
    const std::string l = "skybox.transformer.layers." + std::to_string(i) + ".";
    p.add(l + "self_attn.in_proj_weight", {3 * E, E}, Role::Weight, E);
    p.add(l + "self_attn.in_proj_bias", {3 * E}, Role::Bias, E);
    p.linear(l + "self_attn.out_proj", E, E);
    p.linear(l + "linear1", c.feed_forward, E);
    p.linear(l + "linear2", E, c.feed_forward);
    p.norm(l + "norm1", E);
    p.norm(l + "norm2", E);
  }
}

// fVDB ConvBlock "gcs": GroupNorm over the input width, then a 3x3x3 sparse conv without bias.
void sparse_conv_block(SpecList& p, const std::string& m, int64_t in, int64_t out) {
  p.norm(m + ".GroupNorm", in);
  p.conv(m + ".Conv", out, in, {3, 3, 3}, false);
}

// SparseResBlock: encoder blocks widen in conv2 (conv1 to max(out / 2, in)); a 1x1x1 skip when the width changes.
void sparse_res_block(SpecList& p, const std::string& m, int64_t in, int64_t out, bool encoder) {
  const int64_t mid = encoder ? std::max(out / 2, in) : out;
  sparse_conv_block(p, m + ".conv1", in, mid);
  sparse_conv_block(p, m + ".conv2", mid, out);
  if (in != out) p.conv(m + ".skip_connection", out, in);
}

// Pure3DUnet with its Lifter.
void voxel_branch(SpecList& p, const VoxelUnetConfig& u, const VoxelHeadsConfig& h) {
  const std::string m = "backbone.backbone_3d.";
  p.linear(m + "lifter.mix_fc", u.in_channels, u.image_channels);
  const std::vector<int> n = u.widths();
  const int nb = u.num_blocks;
  auto width = [&](int python_index) { return static_cast<int64_t>(n[static_cast<size_t>(python_index < 0 ? nb + 1 + python_index : python_index)]); };
  for (int l = 0; l < nb; ++l) sparse_res_block(p, m + "encoders.Enc" + std::to_string(l), width(l), width(l + 1), true);
  sparse_res_block(p, m + "pre_kl_bottleneck.pre_kl_bottleneck_0", width(-1), width(-1), false);
  sparse_res_block(p, m + "post_kl_bottleneck.post_kl_bottleneck_0", width(-1), width(-1), false);
  sparse_res_block(p, m + "post_kl_bottleneck.post_kl_bottleneck_1", width(-1), width(-1), false);
  for (int l = -2; l >= -nb; --l)
    sparse_res_block(p, m + "decoders.Dec" + std::to_string(l), width(l + 1) + width(l), width(l), false);
  p.run = false;  // the structure heads: the GSM takes its structure from the input grid
  for (int l = -1; l >= -nb; --l) {
    const std::string s = m + "struct_convs.Struct" + std::to_string(l);
    sparse_conv_block(p, s + ".SingleConv", width(l), width(l));
    p.conv(s + ".OutConv", 2, width(l));
  }
  p.run = true;
  p.conv(m + "pre_conv", u.in_channels, u.in_channels);
  const int64_t outs = static_cast<int64_t>(h.gaussians_per_voxel) * h.gs_dim;
  auto head = [&](const std::string& name, int64_t in) {
    sparse_conv_block(p, m + name + ".SingleConv", in, in);
    p.add(m + name + ".OutConv.weight", {outs, in}, Role::Weight, in);
    p.add(m + name + ".OutConv.bias", {outs}, Role::VoxelGaussianBias, in, h.gs_dim);
  };
  head("render_head_hybrid", h.width_3d + h.width_2d);
  head("render_head_3D", h.width_3d);
}

// x-unet 0.4.0 ResnetBlock on single-frame videos: Block = conv (1, 3, 3) + RMSNorm gamma [C, 1, 1, 1].
void resnet_block(SpecList& p, const std::string& m, int64_t in, int64_t out) {
  p.conv(m + ".block1.proj", out, in, {1, 3, 3});
  p.add(m + ".block1.norm.gamma", {out, 1, 1, 1}, Role::NormWeight);
  p.conv(m + ".block2.proj", out, out, {1, 3, 3});
  p.add(m + ".block2.norm.gamma", {out, 1, 1, 1}, Role::NormWeight);
  if (in != out) p.conv(m + ".res_conv", out, in, {1, 1, 1});
}

void xunet(SpecList& p, const std::string& m, const XUnetConfig& c) {
  const int S = c.stages();
  std::vector<int64_t> dims{c.init_dim};
  for (const int mult : c.dim_mults) dims.push_back(static_cast<int64_t>(c.dim) * mult);
  p.conv(m + "init_conv", c.init_dim, c.channels, {1, 7, 7});
  std::vector<int64_t> skips;
  for (int s = 0; s < S; ++s) {
    const int64_t in = dims[static_cast<size_t>(s)], out = dims[static_cast<size_t>(s) + 1];
    const std::string d = m + "downs." + std::to_string(s);
    skips.push_back(in);
    resnet_block(p, d + ".0", in, in);
    for (int j = 0; j + 1 < c.num_blocks_per_stage[static_cast<size_t>(s)]; ++j) resnet_block(p, d + ".1." + std::to_string(j), in, in);
    p.conv(d + ".3.1", out, in * 4, {1, 1, 1});  // Downsample: space-to-depth, then a 1x1 conv
  }
  for (int u = 0; u + 1 < S; ++u) {
    const int s = S - 2 - u;  // the up stages take the down stages' parameters in reverse, the last left out
    const int64_t in = dims[static_cast<size_t>(s)], out = dims[static_cast<size_t>(s) + 1];
    const std::string d = m + "ups." + std::to_string(u);
    const int64_t skip = skips.back();
    skips.pop_back();
    resnet_block(p, d + ".0", out + skip, out);
    for (int j = 0; j + 1 < c.num_blocks_per_stage[static_cast<size_t>(s)]; ++j) resnet_block(p, d + ".1." + std::to_string(j), out, out);
    p.conv_transpose(d + ".3", out, in, {1, 4, 4});
  }
  const int64_t mid = dims.back();
  resnet_block(p, m + "mid", mid, mid);
  const int64_t inner = static_cast<int64_t>(c.attn_heads.back()) * c.attn_dim_head.back();
  p.add(m + "mid_attn.norm.gamma", {1, mid, 1, 1, 1}, Role::NormWeight);
  p.conv(m + "mid_attn.to_qkv", 3 * inner, mid, {1, 1, 1}, false);
  p.conv(m + "mid_attn.to_out", mid, inner, {1, 1, 1}, false);
  resnet_block(p, m + "mid_after", mid, mid);
  p.conv_transpose(m + "mid_upsample", mid, dims[static_cast<size_t>(S) - 1], {1, 4, 4});
  int64_t final_in = c.dim;
  if (c.consolidate_upsample_fmaps)
    for (int s = 0; s < S; ++s) {
      resnet_block(p, m + "consolidator.fmap_convs." + std::to_string(s), static_cast<int64_t>(c.dim) * c.dim_mults[static_cast<size_t>(s)], c.dim);
      final_in += c.dim;
    }
  resnet_block(p, m + "final_conv.0", final_in + c.dim, c.dim);
  p.conv(m + "final_conv.1", c.out_dim, c.dim, {1, 3, 3});
}

void pixel_branch(SpecList& p, const PixelBranchConfig& c) {
  xunet(p, "backbone.backbone_2d.net.", c.unet);
  const int64_t outs = static_cast<int64_t>(c.gs_per_pixel) * c.gs_dim;
  p.add("backbone.backbone_2d.linear_out.weight", {outs, c.unet.out_dim}, Role::Weight, c.unet.out_dim);
  p.add("backbone.backbone_2d.linear_out.bias", {outs}, Role::PixelGaussianBias, c.unet.out_dim, c.gs_dim);
}

}  // namespace

GsmParamExtras gsm_param_extras_from_json(const nlohmann::json& config, const std::string& source) {
  GsmParamExtras x;
  x.dav2_head_hidden_size = gsm_json::integer(config, "dav2_config.head_hidden_size", source);
  if (x.dav2_head_hidden_size < 1) throw scene::InputError(source, "dav2_config.head_hidden_size", "must be positive");
  const std::string bb = "dav2_config.backbone_config.";
  if (gsm_json::has(config, bb + "qkv_bias")) x.dav2_qkv_bias = gsm_json::boolean(config, bb + "qkv_bias", source);
  if (gsm_json::has(config, bb + "use_mask_token")) x.dav2_mask_token = gsm_json::boolean(config, bb + "use_mask_token", source);
  return x;
}

GsmModelConfig gsm_model_config_from_json(const nlohmann::json& config, const std::string& source) {
  GsmModelConfig m;
  m.config = gsm_config_from_json(config, source);
  m.extras = gsm_param_extras_from_json(config, source);
  return m;
}

GsmModelConfig load_gsm_model_config(const std::string& name_or_path) {
  const GsmConfigJson j = read_gsm_config_json(name_or_path);
  return gsm_model_config_from_json(j.json, j.source);
}

std::vector<GsmParamSpec> gsm_param_specs(const GsmConfig& c, const GsmParamExtras& extras) {
  SpecList p;
  conv_encoder(p, c.conv);
  depth_anything(p, c.dav2, extras);
  dav2_upsampler(p, c.dav2);
  skybox(p, c.sky);
  voxel_branch(p, c.voxel_unet, c.voxel_heads);
  pixel_branch(p, c.pixel);
  return std::move(p.specs);
}

uint64_t gsm_parameter_count(const std::vector<GsmParamSpec>& specs) {
  uint64_t n = 0;
  for (const GsmParamSpec& s : specs)
    if (!s.buffer()) n += static_cast<uint64_t>(product(s.shape));
  return n;
}

uint64_t gsm_buffer_count(const std::vector<GsmParamSpec>& specs) {
  uint64_t n = 0;
  for (const GsmParamSpec& s : specs)
    if (s.buffer()) n += static_cast<uint64_t>(product(s.shape));
  return n;
}

GsmWeights load_gsm_weights(const std::string& path, const GsmModelConfig& model, bool check_finite) {
  return load_gsm_weights(path, gsm_param_specs(model), check_finite);
}

}  // namespace icube::nn
