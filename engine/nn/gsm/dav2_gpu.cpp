// The GSM's Depth-Anything-V2 features on the GPU; see nn/gsm/dav2_gpu.h.
// Test: tests/nn/test_gsm_dav2_gpu.cpp.
#include "nn/gsm/dav2_gpu.h"

#include "gpu/commands.h"
#include "kernels/nn/conv_transpose2d.h"
#include "scene/input_error.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace icube::nn {

namespace {

using kernels::nn::BatchNormActivation;
using kernels::nn::InterpolateMode;

const std::string kEncoder = "img_encoder.encoders.dav2.";
const std::string kModel = kEncoder + "model.";
const std::string kEmbeddings = kModel + "backbone.embeddings.";
const std::string kNeck = kModel + "neck.";

// Derived tensors (add_dav2_gpu_tensors).
const std::string kPixelScale = kEncoder + "pixel_scale";
const std::string kPixelShift = kEncoder + "pixel_shift";
const std::string kClsToken = kEmbeddings + "cls_token_vector";
const std::string kPositionCls = kEmbeddings + "position_cls_vector";
const std::string kPositionGrid = kEmbeddings + "position_grid_channels";
const std::string kLayerScaleShift = kModel + "backbone.layer_scale_shift";
const std::string kTransposedWeight = "transposed_weight";

// torchvision's ImageNet normalisation in the official encoder (as dav2_reference.cpp).

std::string index_name(const std::string& prefix, size_t i) { return prefix + std::to_string(i) + "."; }

void put(Dav2GpuTrace* trace, const std::string& name, const DeviceTensor& x) {
  if (trace) trace->tensors[name] = x;
}

// ---- channel-row copies (the CLS token in and out of the token rows) --------------------------------

// Copies issued between these two see every earlier kernel's and copy's writes, and later kernels see theirs.
void begin_copies(gpu::CommandList& cmd) {
  cmd.barrier(gpu::deps::kComputeToTransfer);
  cmd.barrier(gpu::deps::kTransferToTransfer);
}

void end_copies(gpu::CommandList& cmd) { cmd.barrier(gpu::deps::kTransferToCompute); }

// `count` floats from src[src_index] to dst[dst_index].
void copy_floats(gpu::CommandList& cmd, const gpu::Buffer& src, int64_t src_index, const gpu::Buffer& dst, int64_t dst_index,
                 int64_t count) {
  const auto bytes = static_cast<VkDeviceSize>(count) * 4;
  cmd.copy_buffer(src.binding(static_cast<VkDeviceSize>(src_index) * 4, bytes),
                  dst.binding(static_cast<VkDeviceSize>(dst_index) * 4, bytes));
}

void expect_shape(const LayerRecorder& L, const std::string& name, const std::vector<int64_t>& shape) {
  if (L.params().shape(name) != shape)
    throw std::invalid_argument("dav2_gpu: " + name + " has shape " + shape_text(L.params().shape(name)) + ", the stage needs " +
                                shape_text(shape));
}

// ---- embeddings ----------------------------------------------------------------------------------

// Dinov2Embeddings.interpolate_pos_encoding into `out` [1, C, 1 + gh*gw]: the CLS entry, then the 37x37
// grid resized bicubically (align_corners false, by output size); the training grid is taken as it is.
void record_position_embeddings(LayerRecorder& L, const Dav2Config& cfg, int64_t gh, int64_t gw, const DeviceTensor& out) {
  const int64_t C = cfg.hidden_size, G = cfg.position_grid, hw = gh * gw, T = 1 + hw;
  expect_shape(L, kPositionGrid, {C * G * G});
  expect_shape(L, kPositionCls, {C});
  const DeviceTensor grid = DeviceTensor::borrow(L.params().buffer(kPositionGrid), {1, C, G, G});
  const bool as_trained = hw == G * G && cfg.input_height == cfg.input_width;
  const DeviceTensor resized = as_trained ? grid : L.interpolate(grid, gh, gw, InterpolateMode::bicubic, false);
  gpu::CommandList& cmd = L.cmd();
  begin_copies(cmd);
  for (int64_t c = 0; c < C; ++c) {
    copy_floats(cmd, L.params().buffer(kPositionCls), c, *out.buf, c * T, 1);
    copy_floats(cmd, *resized.buf, c * hw, *out.buf, c * T + 1, hw);
  }
  end_copies(cmd);
}

// Dinov2Embeddings.forward: [V, C, T] = [CLS, patch tokens] (per channel row) + position embeddings.
DeviceTensor embed(LayerRecorder& L, const Dav2Config& cfg, const DeviceTensor& pixel_values, const DeviceTensor& positions) {
  const int64_t V = pixel_values.batch(), C = cfg.hidden_size;
  expect_shape(L, kClsToken, {C});
  const DeviceTensor patches = L.conv2d(pixel_values, kEmbeddings + "patch_embeddings.projection",
                                        static_cast<uint32_t>(cfg.patch_size), 0);
  const int64_t hw = patches.shape[2] * patches.shape[3], T = 1 + hw;
  if (patches.channels() != C || positions.shape != std::vector<int64_t>{1, C, T})
    throw std::invalid_argument("dav2_gpu: patch embedding " + shape_text(patches.shape) + " and position embeddings " +
                                shape_text(positions.shape) + " do not match the hidden size " + std::to_string(C));
  DeviceTensor tokens = L.alloc({V, C, T});
  DeviceTensor position_rows = L.alloc({V, C, T});
  gpu::CommandList& cmd = L.cmd();
  begin_copies(cmd);
  for (int64_t v = 0; v < V; ++v) {
    for (int64_t c = 0; c < C; ++c) {
      copy_floats(cmd, L.params().buffer(kClsToken), c, *tokens.buf, (v * C + c) * T, 1);
      copy_floats(cmd, *patches.buf, (v * C + c) * hw, *tokens.buf, (v * C + c) * T + 1, hw);
    }
    copy_floats(cmd, *positions.buf, 0, *position_rows.buf, v * C * T, C * T);
  }
  end_copies(cmd);
  return L.add(tokens, position_rows);
}

// ---- DINOv2 layers -------------------------------------------------------------------------------

// Layer scale: x * lambda1[c] + 0 (the zero shift leaves the float product as it is).
DeviceTensor layer_scale(LayerRecorder& L, const DeviceTensor& x, const std::string& lambda) {
  return L.channel_affine(x, lambda, kLayerScaleShift, BatchNormActivation::none);
}

// Dinov2Layer on [V, C, T]: x + ls1 * attn(norm1(x)), then + ls2 * mlp(norm2(.)).
DeviceTensor transformer_layer(LayerRecorder& L, const Dav2Config& cfg, const DeviceTensor& x, int64_t index) {
  const std::string l = index_name(kModel + "backbone.encoder.layer.", static_cast<size_t>(index));
  const auto eps = static_cast<float>(cfg.layer_norm_eps);
  const DeviceTensor n1 = L.layer_norm(x, l + "norm1", eps);
  const std::string a = l + "attention.attention.";
  const DeviceTensor context = L.attention(L.conv(n1, a + "query"), L.conv(n1, a + "key"), L.conv(n1, a + "value"),
                                           static_cast<uint32_t>(cfg.num_heads));
  const DeviceTensor attn = L.conv(context, l + "attention.output.dense");
  const DeviceTensor h = L.add(layer_scale(L, attn, l + "layer_scale1.lambda1"), x);
  const DeviceTensor n2 = L.layer_norm(h, l + "norm2", eps);
  const DeviceTensor mlp = L.conv(L.gelu(L.conv(n2, l + "mlp.fc1")), l + "mlp.fc2");
  return L.add(layer_scale(L, mlp, l + "layer_scale2.lambda1"), h);
}

// Dinov2Backbone.forward: the selected hidden states (0 = embeddings), each through the final LayerNorm.
std::vector<DeviceTensor> backbone_feature_maps(LayerRecorder& L, const Dav2Config& cfg, const DeviceTensor& embeddings,
                                                Dav2GpuTrace* trace) {
  const size_t n = cfg.out_indices.size();
  std::vector<DeviceTensor> selected(n);
  auto keep = [&](int64_t hidden_index, const DeviceTensor& h) {
    for (size_t k = 0; k < n; ++k)
      if (cfg.out_indices[k] == hidden_index) selected[k] = h;
  };
  DeviceTensor h = embeddings;
  keep(0, h);
  const int64_t last = *std::max_element(cfg.out_indices.begin(), cfg.out_indices.end());
  for (int64_t i = 0; i < std::min(last, cfg.num_layers); ++i) {
    h = transformer_layer(L, cfg, h, i);
    put(trace, "enc.dav2.layer." + std::to_string(i), h);
    keep(i + 1, h);
  }
  std::vector<DeviceTensor> maps;
  for (size_t k = 0; k < n; ++k) {
    maps.push_back(cfg.apply_layernorm
                       ? L.layer_norm(selected[k], kModel + "backbone.layernorm", static_cast<float>(cfg.layer_norm_eps))
                       : selected[k]);
    put(trace, "enc.dav2.feature_maps." + std::to_string(k), maps.back());
  }
  return maps;
}

// ---- DPT neck ------------------------------------------------------------------------------------

// Tokens [V, C, 1 + gh*gw] -> map [V, C, gh, gw] without the CLS token.
DeviceTensor patch_map(LayerRecorder& L, const DeviceTensor& tokens, int64_t gh, int64_t gw) {
  const int64_t V = tokens.batch(), C = tokens.channels(), hw = gh * gw, T = 1 + hw;
  if (tokens.spatial() != T) throw std::invalid_argument("dav2_gpu: " + shape_text(tokens.shape) + " is not 1 + " + std::to_string(hw) + " tokens");
  DeviceTensor map = L.alloc({V, C, gh, gw});
  gpu::CommandList& cmd = L.cmd();
  begin_copies(cmd);
  for (int64_t r = 0; r < V * C; ++r) copy_floats(cmd, *tokens.buf, r * T + 1, *map.buf, r * hw, hw);
  end_copies(cmd);
  return map;
}

// ConvTranspose2d with kernel = stride = factor (the reassemble up-projection), weights packed in add_dav2_gpu_tensors.
DeviceTensor conv_transpose(LayerRecorder& L, const DeviceTensor& x, const std::string& prefix, int64_t factor) {
  const int64_t C = x.channels();
  expect_shape(L, prefix + ".weight", {C, C, factor, factor});
  kernels::nn::ConvTranspose2dShape s;
  s.batch = static_cast<uint32_t>(x.batch());
  s.in_channels = s.out_channels = static_cast<uint32_t>(C);
  s.height = static_cast<uint32_t>(x.shape[2]);
  s.width = static_cast<uint32_t>(x.shape[3]);
  s.kernel_h = s.kernel_w = s.stride = static_cast<uint32_t>(factor);
  s.padding = 0;
  DeviceTensor y = L.alloc({x.batch(), C, s.out_height(), s.out_width()});
  kernels::nn::ConvTranspose2d op(L.cmd().context());
  const std::string bias = prefix + ".bias";
  op.record(L.cmd(), s, *x.buf, L.params().buffer(prefix + "." + kTransposedWeight),
            L.params().has(bias) ? &L.params().buffer(bias) : nullptr, *y.buf);
  L.barrier();
  return y;
}

// DepthAnythingReassembleLayer: 1x1 projection, then the resampling of `factor`.
DeviceTensor reassemble(LayerRecorder& L, const Dav2Config& cfg, const DeviceTensor& map, size_t k) {
  const std::string r = index_name(kNeck + "reassemble_stage.layers.", k);
  const DeviceTensor p = L.conv2d(map, r + "projection", 1, 0);
  const double factor = cfg.reassemble_factors[k];
  if (factor > 1.0) return conv_transpose(L, p, r + "resize", static_cast<int64_t>(factor));
  if (factor == 1.0) return p;
  return L.conv2d(p, r + "resize", static_cast<uint32_t>(1.0 / factor), 1);
}

// DepthAnythingPreActResidualLayer: x + conv2(relu(conv1(relu(x)))).
DeviceTensor pre_act_residual(LayerRecorder& L, const DeviceTensor& x, const std::string& prefix) {
  const DeviceTensor h1 = L.conv2d(L.relu(x), prefix + "convolution1", 1, 1);
  const DeviceTensor h2 = L.conv2d(L.relu(h1), prefix + "convolution2", 1, 1);
  return L.add(h2, x);
}

// DepthAnythingFeatureFusionLayer: (fused + res1(neck feature)) or the coarsest feature alone, res2,
// bilinear corner-aligned resize to out_h x out_w, 1x1 projection.
DeviceTensor fusion_layer(LayerRecorder& L, size_t index, const DeviceTensor& hidden, const DeviceTensor* residual,
                          int64_t out_h, int64_t out_w) {
  const std::string f = index_name(kNeck + "fusion_stage.layers.", index);
  DeviceTensor h = hidden;
  if (residual) {
    const DeviceTensor r = residual->shape == hidden.shape
                               ? *residual
                               : L.interpolate(*residual, hidden.shape[2], hidden.shape[3], InterpolateMode::bilinear, false);
    h = L.add(h, pre_act_residual(L, r, f + "residual_layer1."));
  }
  h = pre_act_residual(L, h, f + "residual_layer2.");
  h = L.interpolate(h, out_h, out_w, InterpolateMode::bilinear, true);
  return L.conv2d(h, f + "projection", 1, 0);
}

// DepthAnythingNeck.forward: reassemble + 3x3 convs per map, then fusion from the coarsest map up; the last fused map.
DeviceTensor neck(LayerRecorder& L, const Dav2Config& cfg, const std::vector<DeviceTensor>& feature_maps, int64_t gh, int64_t gw,
                  Dav2GpuTrace* trace) {
  const size_t n = feature_maps.size();
  std::vector<DeviceTensor> features;
  for (size_t k = 0; k < n; ++k) {
    const DeviceTensor r = reassemble(L, cfg, patch_map(L, feature_maps[k], gh, gw), k);
    put(trace, "enc.dav2.reassemble." + std::to_string(k), r);
    features.push_back(L.conv2d(r, kNeck + "convs." + std::to_string(k), 1, 1));
    put(trace, "enc.dav2.neck_conv." + std::to_string(k), features.back());
  }
  DeviceTensor fused;
  for (size_t i = 0; i < n; ++i) {
    const DeviceTensor& feature = features[n - 1 - i];
    const DeviceTensor& size_of = i == 0 ? feature : fused;
    const bool last = i + 1 == n;
    const int64_t oh = last ? 2 * size_of.shape[2] : features[n - 2 - i].shape[2];
    const int64_t ow = last ? 2 * size_of.shape[3] : features[n - 2 - i].shape[3];
    fused = i == 0 ? fusion_layer(L, i, feature, nullptr, oh, ow) : fusion_layer(L, i, fused, &feature, oh, ow);
    put(trace, "enc.dav2.fusion." + std::to_string(i), fused);
  }
  return fused;
}

// ---- upsampler -----------------------------------------------------------------------------------

DeviceTensor nearest_x2(LayerRecorder& L, const DeviceTensor& x) {
  return L.interpolate(x, 2 * x.shape[2], 2 * x.shape[3], InterpolateMode::nearest, false);
}

// basic_modules.ResBlock (2-D, BatchNorm, nearest x2): h = conv(nearest(SiLU(BN(x)))), h = conv(SiLU(BN(h))),
// skip(nearest(x)) + h.
DeviceTensor upsampler_block(LayerRecorder& L, const Dav2UpsamplerBlock& b, const DeviceTensor& x, size_t index) {
  const std::string p = index_name(kEncoder + "upsampler.", index);
  DeviceTensor h = L.channel_affine(x, p + "in_layers.0.bn_scale", p + "in_layers.0.bn_shift", BatchNormActivation::silu);
  if (b.up) h = nearest_x2(L, h);
  h = L.conv2d(h, p + "in_layers.2", 1, 1);
  h = L.channel_affine(h, p + "out_layers.0.bn_scale", p + "out_layers.0.bn_shift", BatchNormActivation::silu);
  h = L.conv2d(h, p + "out_layers.3", 1, 1);
  const DeviceTensor xs = b.up ? nearest_x2(L, x) : x;
  const DeviceTensor skip = b.out_dim == x.channels() ? xs : L.conv2d(xs, p + "skip_connection", 1, 0);
  return L.add(skip, h);
}

}  // namespace

void check_dav2_gpu(const Dav2Config& cfg, const std::string& source) {
  if (cfg.use_swiglu_ffn)
    throw scene::InputError(source, "dav2_config.backbone_config.use_swiglu_ffn",
                            "the SwiGLU MLP is not implemented on the GPU (the release uses the GELU MLP)");
  for (const Dav2UpsamplerBlock& b : cfg.upsampler) {
    if (b.down && !b.up)
      throw scene::InputError(source, "hparams.encoder.dav2_params.out_downsample_list",
                              "downsampling upsampler blocks are not implemented on the GPU (the release has none)");
    if (b.group_norm)
      throw scene::InputError(source, "hparams.encoder.dav2_params.out_use_gn_list",
                              "GroupNorm upsampler blocks are not implemented on the GPU (the release uses BatchNorm)");
  }
}

void add_dav2_gpu_tensors(const GsmWeights& w, std::map<std::string, CpuTensor>& out) {
  const std::string cls_name = kEmbeddings + "cls_token", pos_name = kEmbeddings + "position_embeddings";
  if (!w.has(cls_name) || !w.has(pos_name)) return;
  const CpuTensor& cls = w.at(cls_name);
  const CpuTensor& pos = w.at(pos_name);
  const int64_t C = cls.numel();
  const auto G = static_cast<int64_t>(std::llround(std::sqrt(static_cast<double>(pos.numel() / std::max<int64_t>(C, 1) - 1))));
  if (C < 1 || pos.shape != std::vector<int64_t>{1, 1 + G * G, C})
    throw std::invalid_argument("dav2 weights: " + pos_name + " " + pos.shape_text() + " is not [1, 1 + G^2, " +
                                std::to_string(C) + "] for the CLS token " + cls.shape_text());

  CpuTensor scale({3}), shift({3});
  for (size_t c = 0; c < 3; ++c) {
    scale.data[c] = static_cast<float>(1.0 / static_cast<double>(kImageNetStd[c]));
    shift.data[c] = static_cast<float>(-static_cast<double>(kImageNetMean[c]) / static_cast<double>(kImageNetStd[c]));
  }
  out[kPixelScale] = scale;
  out[kPixelShift] = shift;
  out[kClsToken] = CpuTensor({C}, cls.data);
  out[kPositionCls] = CpuTensor({C}, std::vector<float>(pos.data.begin(), pos.data.begin() + C));
  CpuTensor grid({C * G * G});
  for (int64_t p = 0; p < G * G; ++p)
    for (int64_t c = 0; c < C; ++c) grid.data[static_cast<size_t>(c * G * G + p)] = pos.data[static_cast<size_t>((1 + p) * C + c)];
  out[kPositionGrid] = grid;
  out[kLayerScaleShift] = CpuTensor({C});
  // The store would pack these rank-3 tables as matrices (which they are not); the stage reads the flat forms.
  out.erase(cls_name);
  out.erase(pos_name);

  const std::string reassemble = kNeck + "reassemble_stage.layers.";
  for (const auto& [name, t] : w.tensors) {
    if (name.rfind(reassemble, 0) != 0 || t.rank() != 4) continue;
    const std::string tail = ".resize.weight";
    if (name.size() < tail.size() || name.compare(name.size() - tail.size(), tail.size(), tail) != 0) continue;
    const auto ci = static_cast<uint32_t>(t.dim(0)), co = static_cast<uint32_t>(t.dim(1));
    const auto kh = static_cast<uint32_t>(t.dim(2)), kw = static_cast<uint32_t>(t.dim(3));
    std::vector<float> packed = kernels::nn::pack_conv_transpose2d_weights(t.data, ci, co, kh, kw);
    const auto n = static_cast<int64_t>(packed.size());
    out[name.substr(0, name.size() - std::string("weight").size()) + kTransposedWeight] = CpuTensor({n}, std::move(packed));
  }
}

const DeviceTensor& Dav2PositionEmbeddings::get(LayerRecorder& L, const Dav2Config& cfg, int64_t grid_h, int64_t grid_w) {
  const auto key = std::make_pair(grid_h, grid_w);
  const auto it = grids_.find(key);
  if (it != grids_.end()) return it->second;
  gpu::Context* ctx = &L.cmd().context();
  const int64_t C = cfg.hidden_size, T = 1 + grid_h * grid_w;
  DeviceTensor t;
  t.shape = {1, C, T};
  t.buf = std::shared_ptr<gpu::Buffer>(
      new gpu::Buffer(*ctx, static_cast<VkDeviceSize>(C * T) * 4, gpu::MemoryUsage::DeviceLocal, "dav2-position-embeddings"),
      [ctx](gpu::Buffer* b) {
        ctx->retire(std::move(*b));
        delete b;
      });
  record_position_embeddings(L, cfg, grid_h, grid_w, t);
  return grids_.emplace(key, std::move(t)).first->second;
}

DeviceTensor dav2_gpu(LayerRecorder& L, const Dav2Config& cfg, const DeviceTensor& images, Dav2GpuTrace* trace,
                      Dav2PositionEmbeddings* positions) {
  if (images.shape.size() != 4 || images.channels() != 3 || images.batch() < 1)
    throw std::invalid_argument("dav2_gpu: images " + shape_text(images.shape) + " are not [V, 3, H, W]");
  DeviceTensor pixel_values = L.interpolate(images, cfg.input_height, cfg.input_width, InterpolateMode::bilinear, false);
  pixel_values = L.channel_affine(pixel_values, kPixelScale, kPixelShift, BatchNormActivation::none);
  put(trace, "enc.dav2.pixel_values", pixel_values);

  const int64_t gh = cfg.input_height / cfg.patch_size, gw = cfg.input_width / cfg.patch_size;
  DeviceTensor position;
  if (positions) {
    position = positions->get(L, cfg, gh, gw);
  } else {
    position = L.alloc({1, cfg.hidden_size, 1 + gh * gw});
    record_position_embeddings(L, cfg, gh, gw, position);
  }
  put(trace, "enc.dav2.pos_embed_interp", position);
  const DeviceTensor embeddings = embed(L, cfg, pixel_values, position);
  put(trace, "enc.dav2.embeddings", embeddings);

  const std::vector<DeviceTensor> maps = backbone_feature_maps(L, cfg, embeddings, trace);
  DeviceTensor x = neck(L, cfg, maps, gh, gw, trace);
  for (size_t j = 0; j < cfg.upsampler.size(); ++j) {
    x = upsampler_block(L, cfg.upsampler[j], x, j);
    if (j + 1 < cfg.upsampler.size()) put(trace, "enc.dav2.upsampler." + std::to_string(j), x);
  }
  put(trace, "enc.dav2.out", x);
  return x;
}

namespace {

bool is_dav2_token_tensor(const std::string& name) {
  for (const char* stem : {"enc.dav2.pos_embed_interp", "enc.dav2.embeddings", "enc.dav2.layer.", "enc.dav2.feature_maps."})
    if (name.rfind(stem, 0) == 0) return true;
  return false;
}

}  // namespace

GsmTrace download_dav2_trace(gpu::Context& ctx, const Dav2GpuTrace& trace, int64_t batch) {
  GsmTrace out;
  for (const auto& [name, t] : trace.tensors) {
    const CpuTensor x(t.shape, gpu::download_vector<float>(ctx, *t.buf, t.numel()));
    if (is_dav2_token_tensor(name)) {  // [V, C, T] -> [V, T, C]
      const int64_t V = x.dim(0), C = x.dim(1), T = x.dim(2);
      CpuTensor y({V, T, C});
      for (int64_t v = 0; v < V; ++v)
        for (int64_t c = 0; c < C; ++c)
          for (int64_t k = 0; k < T; ++k)
            y.data[static_cast<size_t>((v * T + k) * C + c)] = x.data[static_cast<size_t>((v * C + c) * T + k)];
      out.tensors[name] = std::move(y);
    } else if (name == "enc.dav2.out") {
      out.tensors[name] = CpuTensor({batch, x.dim(0) / batch, x.dim(1), x.dim(2), x.dim(3)}, x.data);
    } else {
      out.tensors[name] = x;
    }
  }
  return out;
}

}  // namespace icube::nn
