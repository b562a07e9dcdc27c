// x-unet's XUnet on the CPU (frame kernel 1); see xunet_reference.h.
#include "nn/gsm/xunet_reference.h"

#include "kernels/nn/attention.h"
#include "kernels/nn/conv2d.h"
#include "kernels/nn/conv_transpose2d.h"
#include "kernels/nn/elementwise.h"
#include "kernels/nn/interpolate.h"
#include "nn/gsm/gsm_json.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace icube::nn {

namespace {

using cpu::detail::D;

const std::string kSource = "the GSM config (unet2d_params)";

// XUnet's cast_tuple: an integer stands for every stage, a list must have one entry per stage. `fallback` (XUnet's
// default) when absent: a list, or one value for every stage.
std::vector<int> per_stage(const nlohmann::json& j, const std::string& key, const std::vector<int>& fallback, int stages) {
  std::vector<int> v = fallback.size() == 1 ? std::vector<int>(static_cast<size_t>(stages), fallback[0]) : fallback;
  if (j.contains(key)) {
    if (j[key].is_number_integer())
      v.assign(static_cast<size_t>(stages), j[key].get<int>());
    else
      v = gsm_json::list<int>(j, key, kSource);
  }
  if (static_cast<int>(v.size()) != stages)
    throw scene::InputError(kSource, key, "needs one entry per stage (" + std::to_string(stages) + ")");
  return v;
}

int integer_or(const nlohmann::json& j, const std::string& key, int fallback) {
  return j.contains(key) ? gsm_json::integer(j, key, kSource) : fallback;
}

bool boolean_or(const nlohmann::json& j, const std::string& key, bool fallback) {
  return j.contains(key) ? gsm_json::boolean(j, key, kSource) : fallback;
}

// --- layers -------------------------------------------------------------------------------------

// A frame-kernel-1 Conv3d weight (out, in, 1, kh, kw) as the 2-D weight (out, in, kh, kw).
CpuTensor conv_weight_2d(const GsmWeights& w, const std::string& name) {
  const CpuTensor& t = w.at(name);
  if (t.rank() != 5 || t.dim(2) != 1)
    throw std::invalid_argument("x-unet: " + name + " " + t.shape_text() + " is not a frame-kernel-1 conv weight (out, in, 1, kh, kw)");
  return CpuTensor({t.dim(0), t.dim(1), t.dim(3), t.dim(4)}, t.data);
}

// WeightStandardizedConv3d's weight: per output channel (w - mean) / sqrt(var + 1e-5), biased variance.
CpuTensor standardized(CpuTensor w) {
  const int64_t per = w.per_item();
  for (int64_t o = 0; o < w.dim(0); ++o) {
    float* p = w.data.data() + o * per;
    double mean = 0.0, var = 0.0;
    for (int64_t i = 0; i < per; ++i) mean += D(p[i]);
    mean /= static_cast<double>(per);
    for (int64_t i = 0; i < per; ++i) var += (D(p[i]) - mean) * (D(p[i]) - mean);
    var /= static_cast<double>(per);
    const double inv = 1.0 / std::sqrt(var + 1e-5);
    for (int64_t i = 0; i < per; ++i) p[i] = static_cast<float>((D(p[i]) - mean) * inv);
  }
  return w;
}

// Conv3d with kernel (1, k, k), "same" padding k / 2, bias if the weights have one.
CpuTensor conv(const GsmWeights& w, const std::string& p, const CpuTensor& x, bool weight_standardize = false) {
  CpuTensor k = conv_weight_2d(w, p + "weight");
  if (k.dim(2) != k.dim(3) || k.dim(2) % 2 == 0)
    throw std::invalid_argument("x-unet: " + p + "weight " + k.shape_text() + " is not an odd square kernel");
  if (weight_standardize) k = standardized(std::move(k));
  const CpuTensor* bias = w.has(p + "bias") ? &w.at(p + "bias") : nullptr;
  return cpu::conv2d(x, k, bias, 1, static_cast<int>(k.dim(2) / 2));
}

// RMSNorm: F.normalize over channels (eps 1e-12) * sqrt(C) * gamma[c].
CpuTensor rms_norm(const CpuTensor& gamma, CpuTensor x) {
  const int64_t B = x.dim(0), C = x.dim(1), S = cpu::detail::spatial_of(x);
  if (gamma.numel() != C) throw std::invalid_argument("x-unet: RMSNorm gamma " + gamma.shape_text() + " does not fit " + x.shape_text());
  const double scale = std::sqrt(static_cast<double>(C));
  for (int64_t b = 0; b < B; ++b)
    for (int64_t s = 0; s < S; ++s) {
      float* p = x.data.data() + b * C * S + s;
      double sq = 0.0;
      for (int64_t c = 0; c < C; ++c) sq += D(p[c * S]) * D(p[c * S]);
      const double inv = scale / std::max(std::sqrt(sq), 1e-12);
      for (int64_t c = 0; c < C; ++c) p[c * S] = static_cast<float>(D(p[c * S]) * inv * D(gamma.data[static_cast<size_t>(c)]));
    }
  return x;
}

// x-unet's LayerNorm: over channels, biased variance, eps 1e-5 (float32), gamma only.
CpuTensor channel_layer_norm(const CpuTensor& gamma, CpuTensor x) {
  const int64_t B = x.dim(0), C = x.dim(1), S = cpu::detail::spatial_of(x);
  if (gamma.numel() != C) throw std::invalid_argument("x-unet: LayerNorm gamma " + gamma.shape_text() + " does not fit " + x.shape_text());
  for (int64_t b = 0; b < B; ++b)
    for (int64_t s = 0; s < S; ++s) {
      float* p = x.data.data() + b * C * S + s;
      double mean = 0.0, var = 0.0;
      for (int64_t c = 0; c < C; ++c) mean += D(p[c * S]);
      mean /= static_cast<double>(C);
      for (int64_t c = 0; c < C; ++c) var += (D(p[c * S]) - mean) * (D(p[c * S]) - mean);
      var /= static_cast<double>(C);
      const double inv = 1.0 / std::sqrt(var + 1e-5);
      for (int64_t c = 0; c < C; ++c) p[c * S] = static_cast<float>((D(p[c * S]) - mean) * inv * D(gamma.data[static_cast<size_t>(c)]));
    }
  return x;
}

// Block: conv 3x3 -> RMSNorm -> SiLU.
CpuTensor block(const XUnetConfig& c, const GsmWeights& w, const std::string& p, const CpuTensor& x) {
  return cpu::silu(rms_norm(w.at(p + "norm.gamma"), conv(w, p + "proj.", x, c.weight_standardize)));
}

// ResnetBlock: block2(block1(x)) + res_conv(x) (identity when the width is kept).
CpuTensor resnet_block(const XUnetConfig& c, const GsmWeights& w, const std::string& p, const CpuTensor& x) {
  const CpuTensor h = block(c, w, p + "block2.", block(c, w, p + "block1.", x));
  return cpu::add(h, w.has(p + "res_conv.weight") ? conv(w, p + "res_conv.", x) : x);
}

// Downsample: 'b c f (h s1) (w s2) -> b (c s1 s2) f h w' (s = 2), then a 1x1 conv.
CpuTensor downsample(const GsmWeights& w, const std::string& p, const CpuTensor& x) {
  const int64_t B = x.dim(0), C = x.dim(1), H = x.dim(2), W = x.dim(3), h = H / 2, wd = W / 2;
  CpuTensor y({B, C * 4, h, wd});
  for (int64_t b = 0; b < B; ++b)
    for (int64_t c = 0; c < C; ++c)
      for (int64_t dy = 0; dy < 2; ++dy)
        for (int64_t dx = 0; dx < 2; ++dx) {
          float* out = y.data.data() + ((b * C + c) * 4 + dy * 2 + dx) * h * wd;
          const float* in = x.data.data() + (b * C + c) * H * W;
          for (int64_t i = 0; i < h; ++i)
            for (int64_t j = 0; j < wd; ++j) out[i * wd + j] = in[(2 * i + dy) * W + 2 * j + dx];
        }
  return conv(w, p, y);
}

// Upsample: ConvTranspose3d kernel (1, 4, 4), stride (1, 2, 2), padding (0, 1, 1).
CpuTensor upsample(const GsmWeights& w, const std::string& p, const CpuTensor& x) {
  const CpuTensor k = conv_weight_2d(w, p + "weight");
  return cpu::conv_transpose2d(x, k, &w.at(p + "bias"), 2, 1);
}

// Attention (with its own residual): x + to_out(softmax(q k^T / sqrt(d)) v), q k v from LayerNorm(x).
CpuTensor mid_attention(const XUnetConfig& c, const GsmWeights& w, const std::string& p, const CpuTensor& x) {
  const int64_t B = x.dim(0), N = cpu::detail::spatial_of(x);
  const int64_t heads = c.attn_heads.back(), dh = c.attn_dim_head.back(), inner = heads * dh;
  const CpuTensor qkv = conv(w, p + "to_qkv.", channel_layer_norm(w.at(p + "norm.gamma"), x));
  if (qkv.dim(1) != 3 * inner)
    throw std::invalid_argument("x-unet: " + p + "to_qkv gives " + std::to_string(qkv.dim(1)) + " channels, not 3 x " +
                                std::to_string(heads) + " heads x " + std::to_string(dh));
  // 'b (h c) f x y -> b h (f x y) c' for q, k, v = the channel thirds.
  CpuTensor q({B, heads, N, dh}), k({B, heads, N, dh}), v({B, heads, N, dh});
  CpuTensor* parts[3] = {&q, &k, &v};
  for (int part = 0; part < 3; ++part)
    for (int64_t b = 0; b < B; ++b)
      for (int64_t h = 0; h < heads; ++h)
        for (int64_t d = 0; d < dh; ++d) {
          const float* src = qkv.data.data() + (b * 3 * inner + part * inner + h * dh + d) * N;
          float* dst = parts[part]->data.data() + (b * heads + h) * N * dh + d;
          for (int64_t n = 0; n < N; ++n) dst[n * dh] = src[n];
        }
  const CpuTensor o = cpu::attention(q, k, v);
  // 'b h (f x y) d -> b (h d) f x y'.
  CpuTensor merged({B, inner, x.dim(2), x.dim(3)});
  for (int64_t b = 0; b < B; ++b)
    for (int64_t h = 0; h < heads; ++h)
      for (int64_t d = 0; d < dh; ++d) {
        const float* src = o.data.data() + (b * heads + h) * N * dh + d;
        float* dst = merged.data.data() + (b * inner + h * dh + d) * N;
        for (int64_t n = 0; n < N; ++n) dst[n] = src[n * dh];
      }
  return cpu::add(conv(w, p + "to_out.", merged), x);
}

CpuTensor as_frames(const CpuTensor& x) {
  return CpuTensor({x.dim(0), x.dim(1), 1, x.dim(2), x.dim(3)}, x.data);
}

CpuTensor concat(const std::vector<const CpuTensor*>& parts) {
  CpuTensor y = *parts.front();
  for (size_t i = 1; i < parts.size(); ++i) y = cpu::concat_channels(y, *parts[i]);
  return y;
}

CpuTensor scaled(CpuTensor x, double s) {
  for (float& v : x.data) v = static_cast<float>(D(v) * s);
  return x;
}

}  // namespace

XUnetConfig xunet_config_from_json(const nlohmann::json& j) {
  if (!j.is_object()) throw scene::InputError(kSource, "", "is not an object");
  XUnetConfig c;
  c.dim = gsm_json::integer(j, "dim", kSource);
  c.channels = integer_or(j, "channels", 3);
  c.init_dim = integer_or(j, "init_dim", c.dim);
  c.out_dim = integer_or(j, "out_dim", c.channels);
  c.dim_mults = j.contains("dim_mults") ? gsm_json::list<int>(j, "dim_mults", kSource) : std::vector<int>{1, 2, 4, 8};
  if (c.dim_mults.empty()) throw scene::InputError(kSource, "dim_mults", "is empty");
  const int s = c.stages();
  c.num_blocks_per_stage = per_stage(j, "num_blocks_per_stage", {2, 2, 2, 2}, s);
  c.num_self_attn_per_stage = per_stage(j, "num_self_attn_per_stage", {0, 0, 0, 1}, s);
  c.attn_heads = per_stage(j, "attn_heads", {8}, s);
  c.attn_dim_head = per_stage(j, "attn_dim_head", {32}, s);
  c.consolidate_upsample_fmaps = boolean_or(j, "consolidate_upsample_fmaps", true);
  c.weight_standardize = boolean_or(j, "weight_standardize", false);
  if (j.contains("skip_scale")) c.skip_scale = gsm_json::number(j, "skip_scale", kSource);
  if (c.dim < 1 || c.channels < 1 || c.init_dim < 1 || c.out_dim < 1)
    throw scene::InputError(kSource, "dim", "dim, channels, init_dim and out_dim must be positive");
  for (int i = 0; i < s; ++i) {
    if (c.dim_mults[static_cast<size_t>(i)] < 1) throw scene::InputError(kSource, "dim_mults", "must be positive");
    if (c.num_blocks_per_stage[static_cast<size_t>(i)] < 1)
      throw scene::InputError(kSource, "num_blocks_per_stage", "must be positive (XUnet asserts it)");
    if (c.num_self_attn_per_stage[static_cast<size_t>(i)] != 0)
      throw std::invalid_argument("x-unet reference: num_self_attn_per_stage must be all 0 (the GSM's); transformer blocks inside "
                                  "stages are not implemented");
    if (c.attn_heads[static_cast<size_t>(i)] < 1 || c.attn_dim_head[static_cast<size_t>(i)] < 1)
      throw scene::InputError(kSource, "attn_heads", "attn_heads and attn_dim_head must be positive");
  }
  if (integer_or(j, "frame_kernel_size", 1) != 1)
    throw std::invalid_argument("x-unet reference: only frame_kernel_size 1 (images) is implemented");
  if (boolean_or(j, "use_convnext", false)) throw std::invalid_argument("x-unet reference: ConvNeXt blocks are not implemented");
  for (int d : per_stage(j, "nested_unet_depths", {0}, s))
    if (d != 0) throw std::invalid_argument("x-unet reference: nested U-Nets (nested_unet_depths > 0) are not implemented");
  return c;
}

CpuTensor xunet_forward(const XUnetConfig& c, const GsmWeights& w, const std::string& prefix, const CpuTensor& input,
                        GsmTrace* trace, const std::string& tp) {
  const int S = c.stages();
  if (S < 1) throw std::invalid_argument("x-unet: no stages");
  if (input.rank() != 4 || input.dim(1) != c.channels)
    throw std::invalid_argument("x-unet: input " + input.shape_text() + " is not [V, " + std::to_string(c.channels) + ", H, W]");
  const int64_t H = input.dim(2), W = input.dim(3), f = int64_t{1} << S;
  if (H % f || W % f)
    throw std::invalid_argument("x-unet: H and W must be multiples of 2^stages = " + std::to_string(f) + ", not " +
                                std::to_string(H) + " x " + std::to_string(W));
  auto put = [&](const std::string& name, const CpuTensor& t) { trace_put(trace, tp + name, as_frames(t)); };

  CpuTensor x = conv(w, prefix + "init_conv.", input);
  put("init_conv", x);
  const CpuTensor r = x;

  std::vector<CpuTensor> down_hiddens;
  for (int s = 0; s < S; ++s) {
    const std::string p = prefix + "downs." + std::to_string(s) + ".";
    const std::string n = "downs." + std::to_string(s) + ".";
    x = resnet_block(c, w, p + "0.", x);
    put(n + "0", x);
    for (int b = 0; b + 1 < c.num_blocks_per_stage[static_cast<size_t>(s)]; ++b) {
      x = resnet_block(c, w, p + "1." + std::to_string(b) + ".", x);
      put(n + "1." + std::to_string(b), x);
    }
    down_hiddens.push_back(x);
    x = downsample(w, p + "3.1.", x);
    put(n + "3", x);
  }

  x = resnet_block(c, w, prefix + "mid.", x);
  put("mid", x);
  const CpuTensor attended = mid_attention(c, w, prefix + "mid_attn.", x);
  put("mid_attn", attended);
  x = resnet_block(c, w, prefix + "mid_after.", cpu::add(attended, x));  // XUnet: mid_attn(x) + x
  put("mid_after", x);
  std::vector<CpuTensor> up_hiddens{x};  // front = finest
  x = upsample(w, prefix + "mid_upsample.", x);
  put("mid_upsample", x);

  // Up stage u mirrors down stage S - 2 - u (XUnet zips reversed(params[:-1])).
  for (int u = 0; u + 1 < S; ++u) {
    const int mirrored = S - 2 - u;
    const std::string p = prefix + "ups." + std::to_string(u) + ".";
    const std::string n = "ups." + std::to_string(u) + ".";
    const CpuTensor skip = scaled(down_hiddens.back(), c.skip_scale);
    down_hiddens.pop_back();
    x = resnet_block(c, w, p + "0.", cpu::concat_channels(x, skip));
    put(n + "0", x);
    for (int b = 0; b + 1 < c.num_blocks_per_stage[static_cast<size_t>(mirrored)]; ++b) {
      x = resnet_block(c, w, p + "1." + std::to_string(b) + ".", x);
      put(n + "1." + std::to_string(b), x);
    }
    up_hiddens.insert(up_hiddens.begin(), x);
    x = upsample(w, p + "3.", x);
    put(n + "3", x);
  }

  if (c.consolidate_upsample_fmaps) {
    // FeatureMapConsolidator: nearest-resize each map to full size, a ResnetBlock, resize again (a no-op), concat after x.
    std::vector<CpuTensor> outs;
    for (size_t i = 0; i < up_hiddens.size(); ++i) {
      const CpuTensor resized = cpu::resize_nearest(up_hiddens[i], H, W);
      outs.push_back(resnet_block(c, w, prefix + "consolidator.fmap_convs." + std::to_string(i) + ".", resized));
    }
    std::vector<const CpuTensor*> parts{&x};
    for (const CpuTensor& o : outs) parts.push_back(&o);
    x = concat(parts);
  }
  put("consolidator", x);

  x = resnet_block(c, w, prefix + "final_conv.0.", cpu::concat_channels(x, r));
  return conv(w, prefix + "final_conv.1.", x);
}

}  // namespace icube::nn
