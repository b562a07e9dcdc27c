// The GSM's sky token and sky colours on the CPU; see sky_reference.h.
#include "nn/gsm/sky_reference.h"

#include "kernels/nn/attention.h"
#include "kernels/nn/conv2d.h"
#include "kernels/nn/conv3d.h"
#include "kernels/nn/elementwise.h"
#include "kernels/nn/layer_norm.h"
#include "nn/gsm/gsm_json.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

namespace icube::nn {

namespace {

const std::string kSky = "skybox.";

void require_value(const nlohmann::json& hparams, const std::string& path, const std::string& want) {
  const std::string got = gsm_json::text(hparams, path);
  if (got == want) return;
  std::string message = "\"";
  message += got;
  message += "\" is not implemented (only \"" + want + "\")";
  throw scene::InputError("the GSM config", path, message);
}

CpuTensor linear_of(const GsmWeights& w, const std::string& p, const CpuTensor& x) {
  return cpu::linear(x, w.at(p + "weight"), w.has(p + "bias") ? &w.at(p + "bias") : nullptr);
}

// PyTorch's nn.TransformerEncoderLayer (post-norm, batch_first, eval) on tokens [n, E].
CpuTensor encoder_layer(const SkyConfig& c, const GsmWeights& w, const std::string& p, const CpuTensor& x) {
  const int64_t n = x.dim(0), E = x.dim(1), H = c.heads, D = E / H;
  const CpuTensor qkv = cpu::linear(x, w.at(p + "self_attn.in_proj_weight", {3 * E, E}), &w.at(p + "self_attn.in_proj_bias"));
  CpuTensor q({1, H, n, D}), k({1, H, n, D}), v({1, H, n, D});
  for (int64_t t = 0; t < n; ++t)
    for (int64_t h = 0; h < H; ++h)
      for (int64_t d = 0; d < D; ++d) {
        const size_t dst = static_cast<size_t>((h * n + t) * D + d);
        const size_t src = static_cast<size_t>(t * 3 * E + h * D + d);
        q.data[dst] = qkv.data[src];
        k.data[dst] = qkv.data[src + static_cast<size_t>(E)];
        v.data[dst] = qkv.data[src + static_cast<size_t>(2 * E)];
      }
  const CpuTensor o = cpu::attention(q, k, v);
  CpuTensor merged({n, E});
  for (int64_t t = 0; t < n; ++t)
    for (int64_t h = 0; h < H; ++h)
      for (int64_t d = 0; d < D; ++d)
        merged.data[static_cast<size_t>(t * E + h * D + d)] = o.data[static_cast<size_t>((h * n + t) * D + d)];
  const CpuTensor sa = linear_of(w, p + "self_attn.out_proj.", merged);
  CpuTensor h1 = cpu::layer_norm(cpu::add(x, sa), w.at(p + "norm1.weight"), w.at(p + "norm1.bias"), 1e-5);
  const CpuTensor ff = linear_of(w, p + "linear2.", cpu::gelu(linear_of(w, p + "linear1.", h1)));
  return cpu::layer_norm(cpu::add(h1, ff), w.at(p + "norm2.weight"), w.at(p + "norm2.bias"), 1e-5);
}

std::array<double, 3> to_opengl_unit(const std::array<double, 3>& d) {
  const std::array<double, 3> g{-d[1], d[2], -d[0]};
  const double n = std::sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]);
  return {g[0] / n, g[1] / n, g[2] / n};
}

// Rotation only: R [u, v, 1] normalised (the official rays subtract the camera centre, or zero it).
std::array<double, 3> rotated_unit(const std::array<float, 16>& pose, double u, double v) {
  std::array<double, 3> d{};
  for (int r = 0; r < 3; ++r)
    d[static_cast<size_t>(r)] = static_cast<double>(pose[static_cast<size_t>(4 * r)]) * u +
                                static_cast<double>(pose[static_cast<size_t>(4 * r + 1)]) * v +
                                static_cast<double>(pose[static_cast<size_t>(4 * r + 2)]);
  const double n = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
  return {d[0] / n, d[1] / n, d[2] / n};
}

}  // namespace

SkyConfig sky_config_from_json(const nlohmann::json& hparams) {
  SkyConfig c;
  if (!gsm_json::boolean(hparams, "use_skybox")) throw scene::InputError("the GSM config", "use_skybox", "a GSM without its sky is not implemented");
  require_value(hparams, "skybox_target", "mlp_modulator");
  require_value(hparams, "skybox_feature_source", "original_rgb");
  const std::string m = "skybox_mlp_modulator.";
  require_value(hparams, m + "sky_token_encoding_type", "transformer");
  require_value(hparams, m + "sky_image_embedder_type", "mlp");
  require_value(hparams, m + "modulator_pos_embedding", "mlp");
  require_value(hparams, m + "transformer.activation", "gelu");
  c.patch_size = gsm_json::integer(hparams, m + "patch_size");
  c.embed_dim = gsm_json::integer(hparams, m + "embed_dim");
  c.hidden_channels = gsm_json::integer(hparams, m + "hidden_channels");
  c.out_channels = gsm_json::integer(hparams, m + "out_channels");
  c.heads = gsm_json::integer(hparams, m + "num_heads");
  c.layers = gsm_json::integer(hparams, m + "transformer.num_layers");
  c.feed_forward = gsm_json::integer(hparams, m + "transformer.dim_feedforward");
  c.model_midground = gsm_json::boolean(hparams, "model_midground");
  if (!c.model_midground)
    throw scene::InputError("the GSM config", "model_midground", "false (sky including the mid-ground) is not implemented");
  if (c.patch_size < 1 || c.embed_dim < 1 || c.heads < 1 || c.embed_dim % c.heads)
    throw scene::InputError("the GSM config", m + "embed_dim", "must be a positive multiple of num_heads");
  return c;
}

std::array<double, 3> sky_pixel_direction(const std::array<float, 16>& pose, const std::array<float, 6>& k, double col, double row) {
  return to_opengl_unit(rotated_unit(pose, (col - static_cast<double>(k[2])) / static_cast<double>(k[0]),
                                     (row - static_cast<double>(k[3])) / static_cast<double>(k[1])));
}

SkyTokenInputs sky_token_inputs(const SkyConfig& c, const GsmWeights& w, const GsmInputs& in, const CpuTensor& patches,
                                GsmTrace* trace) {
  const int64_t B = in.batch, N = in.views, P = c.patch_size, E = c.embed_dim;
  trace_put(trace, "sky.patch_embed", patches);
  const int64_t HP = patches.dim(2), WP = patches.dim(3), per_view = HP * WP;
  SkyTokenInputs r;
  // Used patches: more than 75 % sky pixels (the official ratio > 0.75 of an average over the patch).
  CpuTensor valid({B * N, 1, HP, WP});
  for (int64_t v = 0; v < B * N; ++v)
    for (int64_t i = 0; i < HP; ++i)
      for (int64_t j = 0; j < WP; ++j) {
        int64_t sky = 0;
        for (int64_t row = i * P; row < (i + 1) * P; ++row)
          for (int64_t col = j * P; col < (j + 1) * P; ++col) sky += in.mask(v / N, v % N, row, col, 0) == 0;
        valid.data[static_cast<size_t>((v * HP + i) * WP + j)] = 4 * sky > 3 * P * P ? 1.0f : 0.0f;
      }
  trace_put(trace, "sky.valid_patch_mask", valid);
  // Patch rays: the intrinsics divided by (image size / patch grid), through each patch's first pixel.
  CpuTensor dirs({B, N * per_view, 3});
  for (int64_t v = 0; v < B * N; ++v) {
    const std::array<float, 6>& k = in.intrinsics[static_cast<size_t>(v)];
    // In float32, as the official division of the intrinsics.
    const float sx = k[4] / static_cast<float>(WP), sy = k[5] / static_cast<float>(HP);
    const std::array<float, 6> kp{k[0] / sx, k[1] / sy, k[2] / sx, k[3] / sy, k[4] / sx, k[5] / sy};
    for (int64_t i = 0; i < HP; ++i)
      for (int64_t j = 0; j < WP; ++j) {
        const std::array<double, 3> d = sky_pixel_direction(in.poses[static_cast<size_t>(v)], kp, static_cast<double>(j), static_cast<double>(i));
        for (int a = 0; a < 3; ++a) dirs.data[static_cast<size_t>((v * per_view + i * WP + j) * 3 + a)] = static_cast<float>(d[static_cast<size_t>(a)]);
      }
  }
  trace_put(trace, "sky.pos_embed.in", dirs);
  const CpuTensor pos = linear_of(w, kSky + "pos_embedder.", dirs);
  trace_put(trace, "sky.pos_embed", pos);
  const CpuTensor& query = w.at(kSky + "sky_query", {1, 1, E});
  for (int64_t b = 0; b < B; ++b) {
    std::vector<float> rows(query.data);
    for (int64_t n = 0; n < N; ++n)
      for (int64_t q = 0; q < per_view; ++q) {
        if (valid.data[static_cast<size_t>((b * N + n) * per_view + q)] == 0.0f) continue;
        const int64_t t = n * per_view + q;
        for (int64_t e = 0; e < E; ++e)
          rows.push_back(patches.data[static_cast<size_t>(((b * N + n) * E + e) * per_view + q)] +
                         pos.data[static_cast<size_t>((b * N * per_view + t) * E + e)]);
      }
    const int64_t count = static_cast<int64_t>(rows.size()) / E;
    r.tokens_in.emplace_back(std::vector<int64_t>{count, E}, std::move(rows));
    trace_put(trace, "sky.tokens_in.b" + std::to_string(b), r.tokens_in.back());
  }
  return r;
}

CpuTensor sky_encoder(const SkyConfig& c, const GsmWeights& w, CpuTensor x) {
  for (int l = 0; l < c.layers; ++l) x = encoder_layer(c, w, kSky + "transformer.layers." + std::to_string(l) + ".", x);
  return x;
}

CpuTensor sky_tokens(const SkyConfig& c, const GsmWeights& w, const GsmInputs& in, const CpuTensor& images, GsmTrace* trace) {
  const int64_t P = c.patch_size, E = c.embed_dim;
  const CpuTensor patches = cpu::conv2d(images, w.at(kSky + "patch_embedder.weight", {E, 3, P, P}), &w.at(kSky + "patch_embedder.bias"), c.patch_size, 0);
  const SkyTokenInputs ti = sky_token_inputs(c, w, in, patches, trace);
  CpuTensor tokens({in.batch, E});
  for (int64_t b = 0; b < in.batch; ++b) {
    const CpuTensor x = sky_encoder(c, w, ti.tokens_in[static_cast<size_t>(b)]);
    trace_put(trace, "sky.tokens_out.b" + std::to_string(b), x);
    for (int64_t e = 0; e < E; ++e) tokens.data[static_cast<size_t>(b * E + e)] = x.data[static_cast<size_t>(e)];
  }
  return tokens;
}

std::vector<float> sky_modulation(const SkyConfig& c, const GsmWeights& w, const float* token) {
  const std::string m = kSky + "modulator.";
  const CpuTensor cond = linear_of(w, m + "condition_mapping.", CpuTensor({1, static_cast<int64_t>(c.embed_dim)},
                                                                          std::vector<float>(token, token + c.embed_dim)));
  return linear_of(w, m + "adaLN_modulation.1.", cpu::silu(cond)).data;  // [1, 2 Hc]: shift, then scale
}

CpuTensor sky_colors(const SkyConfig& c, const GsmWeights& w, const float* token, const CpuTensor& directions) {
  const std::string m = kSky + "modulator.";
  const int64_t Hc = c.hidden_channels;
  const std::vector<float> ss = sky_modulation(c, w, token);
  CpuTensor x = linear_of(w, m + "pos_emb.", directions);
  x = cpu::layer_norm(x, CpuTensor({Hc}, 1.0f), CpuTensor({Hc}, 0.0f), 1e-6);
  for (int64_t r = 0; r < x.dim(0); ++r)
    for (int64_t h = 0; h < Hc; ++h) {
      float& v = x.data[static_cast<size_t>(r * Hc + h)];
      v = static_cast<float>(static_cast<double>(v) * (1.0 + static_cast<double>(ss[static_cast<size_t>(Hc + h)])) +
                             static_cast<double>(ss[static_cast<size_t>(h)]));
    }
  return linear_of(w, m + "output.", x);
}

CpuTensor sky_image_directions(const GsmInputs& in) {
  const int64_t N = in.views, H = in.height, W = in.width;
  CpuTensor dirs({in.batch * N * H * W, 3});
  for (int64_t v = 0; v < in.batch * N; ++v)
    for (int64_t r = 0; r < H; ++r)
      for (int64_t col = 0; col < W; ++col) {
        const std::array<double, 3> d = sky_pixel_direction(in.poses[static_cast<size_t>(v)], in.intrinsics[static_cast<size_t>(v)],
                                                            static_cast<double>(col), static_cast<double>(r));
        for (int a = 0; a < 3; ++a) dirs.data[static_cast<size_t>(((v * H + r) * W + col) * 3 + a)] = static_cast<float>(d[static_cast<size_t>(a)]);
      }
  return dirs;
}

CpuTensor sky_image(const SkyConfig& c, const GsmWeights& w, const GsmInputs& in, const CpuTensor& tokens) {
  const int64_t N = in.views, H = in.height, W = in.width, C = c.out_channels, per = N * H * W;
  const CpuTensor all = sky_image_directions(in);
  CpuTensor out({in.batch, N, H, W, C});
  for (int64_t b = 0; b < in.batch; ++b) {
    CpuTensor dirs({per, 3}, std::vector<float>(all.data.begin() + b * per * 3, all.data.begin() + (b + 1) * per * 3));
    const CpuTensor rgb = sky_colors(c, w, tokens.data.data() + b * c.embed_dim, dirs);
    std::copy(rgb.data.begin(), rgb.data.end(), out.data.begin() + b * per * C);
  }
  return out;
}

CpuTensor sky_panorama_directions(int64_t rows) {
  const int64_t cols = 2 * rows;
  CpuTensor dirs({rows * cols, 3});
  for (int64_t i = 0; i < rows; ++i)
    for (int64_t j = 0; j < cols; ++j) {
      // Pixel centres in (0, 1) (as float32, as the official grid), then latitude-longitude to OpenGL axes.
      const double u = static_cast<double>(static_cast<float>((2.0 * static_cast<double>(j) + 1.0) / (2.0 * static_cast<double>(cols))));
      const double v = static_cast<double>(static_cast<float>((2.0 * static_cast<double>(i) + 1.0) / (2.0 * static_cast<double>(rows))));
      const double theta = std::numbers::pi * (2.0 * u - 1.0), phi = std::numbers::pi * v;
      const double d[3] = {std::sin(phi) * std::sin(theta), std::cos(phi), -std::sin(phi) * std::cos(theta)};
      const double n = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
      for (int a = 0; a < 3; ++a) dirs.data[static_cast<size_t>((i * cols + j) * 3 + a)] = static_cast<float>(d[a] / n);
    }
  return dirs;
}

CpuTensor sky_panorama(const SkyConfig& c, const GsmWeights& w, const CpuTensor& tokens, int64_t rows) {
  const int64_t cols = 2 * rows, C = c.out_channels, B = tokens.dim(0);
  const CpuTensor dirs = sky_panorama_directions(rows);
  CpuTensor out({B, rows, cols, C});
  for (int64_t b = 0; b < B; ++b) {
    const CpuTensor rgb = sky_colors(c, w, tokens.data.data() + b * c.embed_dim, dirs);
    std::copy(rgb.data.begin(), rgb.data.end(), out.data.begin() + b * rows * cols * C);
  }
  return out;
}

}  // namespace icube::nn
