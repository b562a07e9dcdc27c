// CPU reference of the GSM's Depth-Anything-V2 features; see nn/gsm/dav2_reference.h.
// Test: tests/nn/test_gsm_dav2_reference.cpp.
#include "nn/gsm/dav2_reference.h"

#include "kernels/nn/attention.h"
#include "kernels/nn/batch_norm.h"
#include "kernels/nn/conv2d.h"
#include "kernels/nn/conv_transpose2d.h"
#include "kernels/nn/conv3d.h"
#include "kernels/nn/elementwise.h"
#include "kernels/nn/group_norm.h"
#include "kernels/nn/interpolate.h"
#include "kernels/nn/layer_norm.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace icube::nn {

namespace {

const std::string kModel = "img_encoder.encoders.dav2.model.";
const std::string kUpsampler = "img_encoder.encoders.dav2.upsampler.";

// torchvision's ImageNet normalisation in the official encoder.

// ---- configuration -------------------------------------------------------------------------------

void fail(const std::string& what) { throw std::invalid_argument("dav2 config: " + what); }

const nlohmann::json& need(const nlohmann::json& obj, const std::string& path, const std::string& key) {
  if (!obj.is_object() || !obj.contains(key)) fail("missing key " + (path.empty() ? key : path + "." + key));
  return obj.at(key);
}

int64_t need_int(const nlohmann::json& obj, const std::string& path, const std::string& key) {
  const nlohmann::json& v = need(obj, path, key);
  if (!v.is_number_integer()) fail(path + "." + key + " is not an integer");
  return v.get<int64_t>();
}

double need_number(const nlohmann::json& obj, const std::string& path, const std::string& key) {
  const nlohmann::json& v = need(obj, path, key);
  if (!v.is_number()) fail(path + "." + key + " is not a number");
  return v.get<double>();
}

bool need_bool(const nlohmann::json& obj, const std::string& path, const std::string& key) {
  const nlohmann::json& v = need(obj, path, key);
  if (!v.is_boolean()) fail(path + "." + key + " is not a boolean");
  return v.get<bool>();
}

const nlohmann::json& need_array(const nlohmann::json& obj, const std::string& path, const std::string& key) {
  const nlohmann::json& v = need(obj, path, key);
  if (!v.is_array()) fail(path + "." + key + " is not a list");
  return v;
}

std::vector<int64_t> need_ints(const nlohmann::json& obj, const std::string& path, const std::string& key) {
  std::vector<int64_t> out;
  for (const nlohmann::json& v : need_array(obj, path, key)) {
    if (!v.is_number_integer()) fail(path + "." + key + " holds a non-integer");
    out.push_back(v.get<int64_t>());
  }
  return out;
}

std::vector<bool> need_bools(const nlohmann::json& obj, const std::string& path, const std::string& key) {
  std::vector<bool> out;
  for (const nlohmann::json& v : need_array(obj, path, key)) {
    if (!v.is_boolean()) fail(path + "." + key + " holds a non-boolean");
    out.push_back(v.get<bool>());
  }
  return out;
}

// ---- small tensor helpers ------------------------------------------------------------------------

// Tokens [V, 1 + h*w, C] -> map [V, C, h, w] without the first (CLS) token.
CpuTensor tokens_to_map(const CpuTensor& tokens, int64_t h, int64_t w) {
  const int64_t V = tokens.dim(0), T = tokens.dim(1), C = tokens.dim(2);
  if (T != 1 + h * w) fail("a hidden state has " + std::to_string(T) + " tokens, the patch grid needs 1 + " + std::to_string(h * w));
  CpuTensor map({V, C, h, w});
  for (int64_t v = 0; v < V; ++v)
    for (int64_t p = 0; p < h * w; ++p)
      for (int64_t c = 0; c < C; ++c)
        map.data[static_cast<size_t>((v * C + c) * h * w + p)] = tokens.data[static_cast<size_t>((v * T + 1 + p) * C + c)];
  return map;
}

// [V, T, heads * D] <-> [V, heads, T, D].
CpuTensor split_heads(const CpuTensor& x, int64_t heads) {
  const int64_t V = x.dim(0), T = x.dim(1), C = x.dim(2), Dh = C / heads;
  CpuTensor y({V, heads, T, Dh});
  for (int64_t v = 0; v < V; ++v)
    for (int64_t t = 0; t < T; ++t)
      for (int64_t h = 0; h < heads; ++h)
        for (int64_t d = 0; d < Dh; ++d)
          y.data[static_cast<size_t>(((v * heads + h) * T + t) * Dh + d)] = x.data[static_cast<size_t>((v * T + t) * C + h * Dh + d)];
  return y;
}

CpuTensor merge_heads(const CpuTensor& x) {
  const int64_t V = x.dim(0), heads = x.dim(1), T = x.dim(2), Dh = x.dim(3);
  CpuTensor y({V, T, heads * Dh});
  for (int64_t v = 0; v < V; ++v)
    for (int64_t h = 0; h < heads; ++h)
      for (int64_t t = 0; t < T; ++t)
        for (int64_t d = 0; d < Dh; ++d)
          y.data[static_cast<size_t>((v * T + t) * heads * Dh + h * Dh + d)] = x.data[static_cast<size_t>(((v * heads + h) * T + t) * Dh + d)];
  return y;
}

// x * scale[c] over the last axis (DINOv2's layer scale).
CpuTensor scale_last_axis(CpuTensor x, const CpuTensor& scale) {
  const size_t C = static_cast<size_t>(scale.numel());
  for (size_t i = 0; i < x.data.size(); ++i) x.data[i] *= scale.data[i % C];
  return x;
}

CpuTensor relu(CpuTensor x) {
  for (float& v : x.data) v = std::max(v, 0.0f);
  return x;
}

// 2x2 average pooling, stride 2 (basic_modules.Downsample without a conv).
CpuTensor avg_pool2(const CpuTensor& x) {
  const int64_t BC = x.dim(0) * x.dim(1), H = x.dim(2), W = x.dim(3), OH = H / 2, OW = W / 2;
  CpuTensor y({x.dim(0), x.dim(1), OH, OW});
  for (int64_t bc = 0; bc < BC; ++bc)
    for (int64_t oy = 0; oy < OH; ++oy)
      for (int64_t ox = 0; ox < OW; ++ox) {
        const float* p = x.data.data() + (bc * H + 2 * oy) * W + 2 * ox;
        const double s = static_cast<double>(p[0]) + static_cast<double>(p[1]) + static_cast<double>(p[W]) + static_cast<double>(p[W + 1]);
        y.data[static_cast<size_t>((bc * OH + oy) * OW + ox)] = static_cast<float>(s / 4.0);
      }
  return y;
}

// ---- DINOv2 backbone -----------------------------------------------------------------------------

// Dinov2Embeddings.interpolate_pos_encoding: [1, 1 + gh*gw, C], the CLS entry unchanged and the
// position grid resized bicubically (align_corners false) to the patch grid by output size.
CpuTensor interpolated_position_embeddings(const Dav2Config& cfg, const GsmWeights& w, int64_t gh, int64_t gw,
                                           int64_t height, int64_t width) {
  const int64_t G = cfg.position_grid, C = cfg.hidden_size;
  const CpuTensor& pos = w.at(kModel + "backbone.embeddings.position_embeddings", {1, 1 + G * G, C});
  if (gh * gw == G * G && height == width) return pos;
  CpuTensor grid({1, C, G, G});
  for (int64_t p = 0; p < G * G; ++p)
    for (int64_t c = 0; c < C; ++c) grid.data[static_cast<size_t>(c * G * G + p)] = pos.data[static_cast<size_t>((1 + p) * C + c)];
  const CpuTensor resized = cpu::resize_bicubic(grid, gh, gw, false);
  CpuTensor out({1, 1 + gh * gw, C});
  std::copy(pos.data.begin(), pos.data.begin() + C, out.data.begin());
  for (int64_t p = 0; p < gh * gw; ++p)
    for (int64_t c = 0; c < C; ++c)
      out.data[static_cast<size_t>((1 + p) * C + c)] = resized.data[static_cast<size_t>(c * gh * gw + p)];
  return out;
}

// Dinov2Embeddings.forward: [V, 1 + gh*gw, C] = [CLS, patch tokens] + position embeddings.
CpuTensor embed(const Dav2Config& cfg, const GsmWeights& w, const CpuTensor& pixel_values, GsmTrace* trace) {
  const int64_t V = pixel_values.dim(0), C = cfg.hidden_size, P = cfg.patch_size;
  const std::string e = kModel + "backbone.embeddings.";
  const CpuTensor patches =
      cpu::conv2d(pixel_values, w.at(e + "patch_embeddings.projection.weight", {C, 3, P, P}),
                  &w.at(e + "patch_embeddings.projection.bias", {C}), static_cast<int>(P), 0);
  const int64_t gh = patches.dim(2), gw = patches.dim(3), T = 1 + gh * gw;
  const CpuTensor pos = interpolated_position_embeddings(cfg, w, gh, gw, pixel_values.dim(2), pixel_values.dim(3));
  trace_put(trace, "enc.dav2.pos_embed_interp", pos);
  const CpuTensor& cls = w.at(e + "cls_token", {1, 1, C});
  CpuTensor tokens({V, T, C});
  for (int64_t v = 0; v < V; ++v)
    for (int64_t t = 0; t < T; ++t)
      for (int64_t c = 0; c < C; ++c) {
        const float x = t == 0 ? cls.data[static_cast<size_t>(c)]
                               : patches.data[static_cast<size_t>((v * C + c) * gh * gw + (t - 1))];
        tokens.data[static_cast<size_t>((v * T + t) * C + c)] = x + pos.data[static_cast<size_t>(t * C + c)];
      }
  trace_put(trace, "enc.dav2.embeddings", tokens);
  return tokens;
}

// Dinov2Layer: x + ls1 * attn(norm1(x)), then + ls2 * mlp(norm2(.)).
CpuTensor transformer_layer(const Dav2Config& cfg, const GsmWeights& w, const CpuTensor& x, int64_t index) {
  const int64_t C = cfg.hidden_size;
  const std::string l = kModel + "backbone.encoder.layer." + std::to_string(index) + ".";
  auto bias = [&](const std::string& name, int64_t n) -> const CpuTensor* {
    return w.has(l + name) ? &w.at(l + name, {n}) : nullptr;
  };
  const CpuTensor n1 = cpu::layer_norm(x, w.at(l + "norm1.weight", {C}), w.at(l + "norm1.bias", {C}), cfg.layer_norm_eps);
  const std::string a = "attention.attention.";
  const CpuTensor q = cpu::linear(n1, w.at(l + a + "query.weight", {C, C}), bias(a + "query.bias", C));
  const CpuTensor k = cpu::linear(n1, w.at(l + a + "key.weight", {C, C}), bias(a + "key.bias", C));
  const CpuTensor v = cpu::linear(n1, w.at(l + a + "value.weight", {C, C}), bias(a + "value.bias", C));
  const CpuTensor context =
      merge_heads(cpu::attention(split_heads(q, cfg.num_heads), split_heads(k, cfg.num_heads), split_heads(v, cfg.num_heads)));
  const CpuTensor attn = cpu::linear(context, w.at(l + "attention.output.dense.weight", {C, C}),
                                     &w.at(l + "attention.output.dense.bias", {C}));
  const CpuTensor h = cpu::add(scale_last_axis(attn, w.at(l + "layer_scale1.lambda1", {C})), x);

  const CpuTensor n2 = cpu::layer_norm(h, w.at(l + "norm2.weight", {C}), w.at(l + "norm2.bias", {C}), cfg.layer_norm_eps);
  CpuTensor mlp;
  if (cfg.use_swiglu_ffn) {
    // Dinov2SwiGLUFFN: hidden = (int(mlp_hidden * 2 / 3) + 7) // 8 * 8; silu(x1) * x2 of the two halves.
    const int64_t hid = (cfg.mlp_hidden * 2 / 3 + 7) / 8 * 8;
    CpuTensor in = cpu::linear(n2, w.at(l + "mlp.weights_in.weight", {2 * hid, C}), &w.at(l + "mlp.weights_in.bias", {2 * hid}));
    const int64_t rows = in.numel() / (2 * hid);
    CpuTensor gated({x.dim(0), x.dim(1), hid});
    for (int64_t r = 0; r < rows; ++r)
      for (int64_t j = 0; j < hid; ++j) {
        const float x1 = in.data[static_cast<size_t>(r * 2 * hid + j)], x2 = in.data[static_cast<size_t>(r * 2 * hid + hid + j)];
        const float s = static_cast<float>(static_cast<double>(x1) / (1.0 + std::exp(-static_cast<double>(x1))));
        gated.data[static_cast<size_t>(r * hid + j)] = s * x2;
      }
    mlp = cpu::linear(gated, w.at(l + "mlp.weights_out.weight", {C, hid}), &w.at(l + "mlp.weights_out.bias", {C}));
  } else {
    const int64_t hid = cfg.mlp_hidden;
    const CpuTensor f1 = cpu::gelu(cpu::linear(n2, w.at(l + "mlp.fc1.weight", {hid, C}), &w.at(l + "mlp.fc1.bias", {hid})));
    mlp = cpu::linear(f1, w.at(l + "mlp.fc2.weight", {C, hid}), &w.at(l + "mlp.fc2.bias", {C}));
  }
  return cpu::add(scale_last_axis(mlp, w.at(l + "layer_scale2.lambda1", {C})), h);
}

// Dinov2Backbone.forward: the selected hidden states (0 = embeddings), each through the final LayerNorm.
std::vector<CpuTensor> backbone_feature_maps(const Dav2Config& cfg, const GsmWeights& w, const CpuTensor& pixel_values,
                                             GsmTrace* trace) {
  std::vector<CpuTensor> hidden{embed(cfg, w, pixel_values, trace)};
  const int64_t last = *std::max_element(cfg.out_indices.begin(), cfg.out_indices.end());
  for (int64_t i = 0; i < std::min(last, cfg.num_layers); ++i) {
    hidden.push_back(transformer_layer(cfg, w, hidden.back(), i));
    trace_put(trace, "enc.dav2.layer." + std::to_string(i), hidden.back());
  }
  const int64_t C = cfg.hidden_size;
  std::vector<CpuTensor> maps;
  for (size_t k = 0; k < cfg.out_indices.size(); ++k) {
    const CpuTensor& h = hidden[static_cast<size_t>(cfg.out_indices[k])];
    maps.push_back(cfg.apply_layernorm ? cpu::layer_norm(h, w.at(kModel + "backbone.layernorm.weight", {C}),
                                                         w.at(kModel + "backbone.layernorm.bias", {C}), cfg.layer_norm_eps)
                                       : h);
    trace_put(trace, "enc.dav2.feature_maps." + std::to_string(k), maps.back());
  }
  return maps;
}

// ---- DPT neck ------------------------------------------------------------------------------------

// DepthAnythingReassembleLayer: 1x1 projection, then the resampling of `factor`.
CpuTensor reassemble(const Dav2Config& cfg, const GsmWeights& w, const CpuTensor& map, size_t k) {
  const int64_t C = cfg.hidden_size, Co = cfg.neck_hidden_sizes[k];
  const double factor = cfg.reassemble_factors[k];
  const std::string r = kModel + "neck.reassemble_stage.layers." + std::to_string(k) + ".";
  const CpuTensor p = cpu::conv2d(map, w.at(r + "projection.weight", {Co, C, 1, 1}), &w.at(r + "projection.bias", {Co}));
  if (factor > 1.0) {
    const int64_t f = static_cast<int64_t>(factor);
    return cpu::conv_transpose2d(p, w.at(r + "resize.weight", {Co, Co, f, f}), &w.at(r + "resize.bias", {Co}), static_cast<int>(f), 0);
  }
  if (factor == 1.0) return p;
  const int stride = static_cast<int>(1.0 / factor);
  return cpu::conv2d(p, w.at(r + "resize.weight", {Co, Co, 3, 3}), &w.at(r + "resize.bias", {Co}), stride, 1);
}

// DepthAnythingPreActResidualLayer: x + conv2(relu(conv1(relu(x)))).
CpuTensor pre_act_residual(const Dav2Config& cfg, const GsmWeights& w, const CpuTensor& x, const std::string& prefix) {
  const int64_t F = cfg.fusion_hidden_size;
  const CpuTensor h1 = cpu::conv2d(relu(x), w.at(prefix + "convolution1.weight", {F, F, 3, 3}),
                                   &w.at(prefix + "convolution1.bias", {F}), 1, 1);
  const CpuTensor h2 = cpu::conv2d(relu(h1), w.at(prefix + "convolution2.weight", {F, F, 3, 3}),
                                   &w.at(prefix + "convolution2.bias", {F}), 1, 1);
  return cpu::add(h2, x);
}

// DepthAnythingFeatureFusionLayer: (fused + res1(neck feature)) or the coarsest feature alone, res2,
// bilinear corner-aligned resize to `out_h x out_w`, 1x1 projection.
CpuTensor fusion_layer(const Dav2Config& cfg, const GsmWeights& w, size_t index, const CpuTensor& hidden,
                       const CpuTensor* residual, int64_t out_h, int64_t out_w) {
  const int64_t F = cfg.fusion_hidden_size;
  const std::string f = kModel + "neck.fusion_stage.layers." + std::to_string(index) + ".";
  CpuTensor h = hidden;
  if (residual) {
    // A neck feature of another size is first resized to the fused map (bilinear, half-pixel centres).
    const CpuTensor r = residual->shape == hidden.shape ? *residual
                                                        : cpu::resize_bilinear(*residual, hidden.dim(2), hidden.dim(3), false);
    h = cpu::add(h, pre_act_residual(cfg, w, r, f + "residual_layer1."));
  }
  h = pre_act_residual(cfg, w, h, f + "residual_layer2.");
  h = cpu::resize_bilinear(h, out_h, out_w, true);
  return cpu::conv2d(h, w.at(f + "projection.weight", {F, F, 1, 1}), &w.at(f + "projection.bias", {F}));
}

// DepthAnythingNeck.forward: the fusion maps, coarsest first (the last is the finest).
std::vector<CpuTensor> neck(const Dav2Config& cfg, const GsmWeights& w, const std::vector<CpuTensor>& feature_maps,
                            int64_t gh, int64_t gw, GsmTrace* trace) {
  const size_t n = feature_maps.size();
  std::vector<CpuTensor> features;
  for (size_t k = 0; k < n; ++k) {
    const CpuTensor r = reassemble(cfg, w, tokens_to_map(feature_maps[k], gh, gw), k);
    trace_put(trace, "enc.dav2.reassemble." + std::to_string(k), r);
    const int64_t Ck = cfg.neck_hidden_sizes[k], F = cfg.fusion_hidden_size;
    features.push_back(cpu::conv2d(r, w.at(kModel + "neck.convs." + std::to_string(k) + ".weight", {F, Ck, 3, 3}), nullptr, 1, 1));
    trace_put(trace, "enc.dav2.neck_conv." + std::to_string(k), features.back());
  }
  // DepthAnythingFeatureFusionStage: from the last (coarsest) feature up; each layer resizes to the
  // next feature's size, the last one by 2 (output floor(2 n), corner-aligned).
  std::vector<CpuTensor> fused;
  for (size_t i = 0; i < n; ++i) {
    const CpuTensor& feature = features[n - 1 - i];
    const bool last = i + 1 == n;
    const int64_t oh = last ? 2 * (i == 0 ? feature.dim(2) : fused.back().dim(2)) : features[n - 2 - i].dim(2);
    const int64_t ow = last ? 2 * (i == 0 ? feature.dim(3) : fused.back().dim(3)) : features[n - 2 - i].dim(3);
    fused.push_back(i == 0 ? fusion_layer(cfg, w, i, feature, nullptr, oh, ow)
                           : fusion_layer(cfg, w, i, fused.back(), &feature, oh, ow));
    trace_put(trace, "enc.dav2.fusion." + std::to_string(i), fused.back());
  }
  return fused;
}

// ---- upsampler -----------------------------------------------------------------------------------

CpuTensor block_norm(const Dav2UpsamplerBlock& b, const GsmWeights& w, const CpuTensor& x, const std::string& prefix) {
  const int64_t C = x.dim(1);
  if (b.group_norm) return cpu::group_norm(x, 32, w.at(prefix + "weight", {C}), w.at(prefix + "bias", {C}), 1e-5);
  return cpu::batch_norm(x, w.at(prefix + "weight", {C}), w.at(prefix + "bias", {C}), w.at(prefix + "running_mean", {C}),
                         w.at(prefix + "running_var", {C}), 1e-5);
}

CpuTensor resample(const Dav2UpsamplerBlock& b, const CpuTensor& x) {
  if (b.up) return cpu::resize_nearest(x, 2 * x.dim(2), 2 * x.dim(3));
  if (b.down) return avg_pool2(x);
  return x;
}

// basic_modules.ResBlock (2-D, no timestep): h = conv(SiLU(norm(x))) with the resampling after the
// SiLU, h = conv(SiLU(norm(h))), skip(resampled x) + h.
CpuTensor upsampler_block(const Dav2UpsamplerBlock& b, const GsmWeights& w, const CpuTensor& x, size_t index) {
  const int64_t Ci = x.dim(1), Co = b.out_dim;
  const std::string p = kUpsampler + std::to_string(index) + ".";
  CpuTensor h = resample(b, cpu::silu(block_norm(b, w, x, p + "in_layers.0.")));
  h = cpu::conv2d(h, w.at(p + "in_layers.2.weight", {Co, Ci, 3, 3}), &w.at(p + "in_layers.2.bias", {Co}), 1, 1);
  h = cpu::silu(block_norm(b, w, h, p + "out_layers.0."));
  h = cpu::conv2d(h, w.at(p + "out_layers.3.weight", {Co, Co, 3, 3}), &w.at(p + "out_layers.3.bias", {Co}), 1, 1);
  const CpuTensor xs = resample(b, x);
  const CpuTensor skip = Co == Ci ? xs
                                  : cpu::conv2d(xs, w.at(p + "skip_connection.weight", {Co, Ci, 1, 1}),
                                                &w.at(p + "skip_connection.bias", {Co}));
  return cpu::add(skip, h);
}

// ---- input ---------------------------------------------------------------------------------------

// Bilinear resize (half-pixel centres, no antialiasing) to the target size, then (x - mean) / std in float32.
CpuTensor pixel_values_of(const Dav2Config& cfg, const CpuTensor& images) {
  CpuTensor x = cpu::resize_bilinear(images, cfg.input_height, cfg.input_width, false);
  const int64_t plane = cfg.input_height * cfg.input_width;
  for (int64_t i = 0; i < x.numel(); ++i) {
    const int64_t c = (i / plane) % 3;
    float& v = x.data[static_cast<size_t>(i)];
    v = (v - kImageNetMean[c]) / kImageNetStd[c];
  }
  return x;
}

}  // namespace

Dav2Config dav2_config_from_json(const nlohmann::json& case_config) {
  Dav2Config cfg;
  const nlohmann::json& dav2 = need(case_config, "", "dav2_config");
  const std::string bp = "dav2_config.backbone_config";
  const nlohmann::json& bb = need(dav2, "dav2_config", "backbone_config");
  cfg.hidden_size = need_int(bb, bp, "hidden_size");
  cfg.num_layers = need_int(bb, bp, "num_hidden_layers");
  cfg.num_heads = need_int(bb, bp, "num_attention_heads");
  cfg.patch_size = need_int(bb, bp, "patch_size");
  cfg.mlp_hidden = static_cast<int64_t>(static_cast<double>(cfg.hidden_size) * need_number(bb, bp, "mlp_ratio"));
  const int64_t image_size = need_int(bb, bp, "image_size");
  cfg.layer_norm_eps = need_number(bb, bp, "layer_norm_eps");
  cfg.use_swiglu_ffn = need_bool(bb, bp, "use_swiglu_ffn");
  cfg.apply_layernorm = need_bool(bb, bp, "apply_layernorm");
  cfg.out_indices = need_ints(bb, bp, "out_indices");
  if (cfg.hidden_size <= 0 || cfg.num_layers <= 0 || cfg.num_heads <= 0 || cfg.patch_size <= 0 || cfg.mlp_hidden <= 0)
    fail(bp + ": sizes must be positive");
  if (cfg.hidden_size % cfg.num_heads) fail(bp + ": hidden_size is not a multiple of num_attention_heads");
  if (image_size < cfg.patch_size) fail(bp + ".image_size is smaller than patch_size");
  cfg.position_grid = image_size / cfg.patch_size;
  if (need(bb, bp, "hidden_act") != "gelu") fail(bp + ".hidden_act: only \"gelu\" (exact) is supported");
  if (need_int(bb, bp, "num_channels") != 3) fail(bp + ".num_channels: the encoder feeds RGB (3)");
  if (need_bool(bb, bp, "reshape_hidden_states"))
    fail(bp + ".reshape_hidden_states: the Depth-Anything neck takes token sequences (false)");
  if (cfg.out_indices.empty()) fail(bp + ".out_indices is empty");
  for (int64_t i : cfg.out_indices)
    if (i < 0 || i > cfg.num_layers) fail(bp + ".out_indices: " + std::to_string(i) + " is not a hidden-state index");

  cfg.neck_hidden_sizes = need_ints(dav2, "dav2_config", "neck_hidden_sizes");
  for (const nlohmann::json& f : need_array(dav2, "dav2_config", "reassemble_factors")) {
    if (!f.is_number()) fail("dav2_config.reassemble_factors holds a non-number");
    cfg.reassemble_factors.push_back(f.get<double>());
  }
  cfg.fusion_hidden_size = need_int(dav2, "dav2_config", "fusion_hidden_size");
  if (need_int(dav2, "dav2_config", "reassemble_hidden_size") != cfg.hidden_size)
    fail("dav2_config.reassemble_hidden_size differs from the backbone's hidden_size");
  if (need_int(dav2, "dav2_config", "patch_size") != cfg.patch_size)
    fail("dav2_config.patch_size differs from the backbone's patch_size");
  if (cfg.neck_hidden_sizes.size() != cfg.out_indices.size() || cfg.reassemble_factors.size() != cfg.out_indices.size())
    fail("dav2_config: neck_hidden_sizes, reassemble_factors and backbone out_indices differ in length");
  if (cfg.neck_hidden_sizes.size() < 2) fail("dav2_config.neck_hidden_sizes: the fusion stage needs at least 2 maps");
  for (double f : cfg.reassemble_factors) {
    const bool up = f > 1.0 && f == std::floor(f);
    const bool down = f > 0.0 && f < 1.0 && 1.0 / f == std::floor(1.0 / f);
    if (!(up || f == 1.0 || down)) fail("dav2_config.reassemble_factors: " + std::to_string(f) + " is not k or 1/k");
  }

  const std::string ep = "hparams.encoder.dav2_params";
  const nlohmann::json& params = need(need(need(case_config, "", "hparams"), "hparams", "encoder"), "hparams.encoder", "dav2_params");
  const std::vector<int64_t> size = need_ints(params, ep, "target_input_size");
  if (size.size() != 2 || size[0] < cfg.patch_size || size[1] < cfg.patch_size)
    fail(ep + ".target_input_size must be [height, width], each at least one patch");
  cfg.input_height = size[0];
  cfg.input_width = size[1];
  const std::vector<int64_t> dims = need_ints(params, ep, "out_dim_list");
  const std::vector<bool> up = need_bools(params, ep, "out_upsample_list");
  const std::vector<bool> down = need_bools(params, ep, "out_downsample_list");
  const std::vector<bool> gn = need_bools(params, ep, "out_use_gn_list");
  if (dims.empty()) fail(ep + ".out_dim_list is empty");
  if (up.size() != dims.size() || down.size() != dims.size() || gn.size() != dims.size())
    fail(ep + ": out_dim_list, out_upsample_list, out_downsample_list and out_use_gn_list differ in length");
  int64_t in_dim = cfg.fusion_hidden_size;
  for (size_t i = 0; i < dims.size(); ++i) {
    if (dims[i] <= 0) fail(ep + ".out_dim_list: widths must be positive");
    if (gn[i] && (in_dim % 32 || dims[i] % 32)) fail(ep + ".out_use_gn_list: GroupNorm(32) needs widths divisible by 32");
    cfg.upsampler.push_back({dims[i], up[i], down[i], gn[i]});
    in_dim = dims[i];
  }
  return cfg;
}

CpuTensor dav2_features(const Dav2Config& cfg, const GsmWeights& weights, const CpuTensor& images, GsmTrace* trace,
                        int64_t batch) {
  if (images.rank() != 4 || images.dim(1) != 3 || images.dim(0) < 1)
    throw std::invalid_argument("dav2_features: images " + images.shape_text() + " are not [V, 3, H, W]");
  if (batch < 1 || images.dim(0) % batch)
    throw std::invalid_argument("dav2_features: " + std::to_string(images.dim(0)) + " views do not split into " +
                                std::to_string(batch) + " batch elements");
  const CpuTensor pixel_values = pixel_values_of(cfg, images);
  trace_put(trace, "enc.dav2.pixel_values", pixel_values);
  const std::vector<CpuTensor> maps = backbone_feature_maps(cfg, weights, pixel_values, trace);
  const int64_t gh = cfg.input_height / cfg.patch_size, gw = cfg.input_width / cfg.patch_size;
  CpuTensor x = neck(cfg, weights, maps, gh, gw, trace).back();
  for (size_t j = 0; j < cfg.upsampler.size(); ++j) {
    x = upsampler_block(cfg.upsampler[j], weights, x, j);
    if (j + 1 < cfg.upsampler.size()) trace_put(trace, "enc.dav2.upsampler." + std::to_string(j), x);
  }
  if (trace) {
    CpuTensor out = x;
    out.shape.insert(out.shape.begin(), batch);
    out.shape[1] /= batch;
    trace_put(trace, "enc.dav2.out", out);
  }
  return x;
}

}  // namespace icube::nn
