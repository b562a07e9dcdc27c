// The dense diffusion UNet as a CPU reference; see unet_reference.h.
#include "nn/unet_reference.h"

#include "kernels/nn/attention.h"
#include "kernels/nn/conv3d.h"
#include "kernels/nn/cpu_tensor.h"
#include "kernels/nn/elementwise.h"
#include "kernels/nn/group_norm.h"
#include "kernels/nn/layer_norm.h"
#include "kernels/nn/resample.h"
#include "nn/timestep_embedding.h"

#include <algorithm>
#include <stdexcept>

namespace icube::nn {

namespace {

using Kind = UNetReference::Layer::Kind;

bool contains(const std::vector<int>& v, int x) { return std::find(v.begin(), v.end(), x) != v.end(); }

// [B, C, S...] <-> [B, H, N, D] with C = H * D ("b (h d) n -> b h n d").
CpuTensor split_heads_channels_first(const CpuTensor& x, int64_t c0, int64_t C_total, int heads, int64_t D, int64_t N) {
  const int64_t B = x.dim(0);
  CpuTensor y({B, heads, N, D});
  for (int64_t b = 0; b < B; ++b)
    for (int64_t h = 0; h < heads; ++h)
      for (int64_t n = 0; n < N; ++n)
        for (int64_t d = 0; d < D; ++d)
          y.data[static_cast<size_t>(((b * heads + h) * N + n) * D + d)] =
              x.data[static_cast<size_t>((b * C_total + c0 + h * D + d) * N + n)];
  return y;
}

// [B, N, C] -> [B, H, N, D] ("b n (h d) -> b h n d").
CpuTensor split_heads_tokens(const CpuTensor& x, int heads) {
  const int64_t B = x.dim(0), N = x.dim(1), C = x.dim(2), D = C / heads;
  CpuTensor y({B, heads, N, D});
  for (int64_t b = 0; b < B; ++b)
    for (int64_t n = 0; n < N; ++n)
      for (int64_t h = 0; h < heads; ++h)
        for (int64_t d = 0; d < D; ++d)
          y.data[static_cast<size_t>(((b * heads + h) * N + n) * D + d)] = x.data[static_cast<size_t>((b * N + n) * C + h * D + d)];
  return y;
}

// [B, H, N, D] -> [B, N, H*D].
CpuTensor merge_heads_tokens(const CpuTensor& x) {
  const int64_t B = x.dim(0), H = x.dim(1), N = x.dim(2), D = x.dim(3);
  CpuTensor y({B, N, H * D});
  for (int64_t b = 0; b < B; ++b)
    for (int64_t h = 0; h < H; ++h)
      for (int64_t n = 0; n < N; ++n)
        for (int64_t d = 0; d < D; ++d)
          y.data[static_cast<size_t>((b * N + n) * H * D + h * D + d)] = x.data[static_cast<size_t>(((b * H + h) * N + n) * D + d)];
  return y;
}

// [B, C, S...] <-> [B, S, C].
CpuTensor to_tokens(const CpuTensor& x) {
  const int64_t B = x.dim(0), C = x.dim(1), S = x.per_item() / C;
  CpuTensor y({B, S, C});
  for (int64_t b = 0; b < B; ++b)
    for (int64_t c = 0; c < C; ++c)
      for (int64_t s = 0; s < S; ++s) y.data[static_cast<size_t>((b * S + s) * C + c)] = x.data[static_cast<size_t>((b * C + c) * S + s)];
  return y;
}

CpuTensor from_tokens(const CpuTensor& t, const std::vector<int64_t>& shape) {
  const int64_t B = t.dim(0), S = t.dim(1), C = t.dim(2);
  std::vector<int64_t> s = shape;
  s[1] = C;
  CpuTensor y(s);
  for (int64_t b = 0; b < B; ++b)
    for (int64_t c = 0; c < C; ++c)
      for (int64_t i = 0; i < S; ++i) y.data[static_cast<size_t>((b * C + c) * S + i)] = t.data[static_cast<size_t>((b * S + i) * C + c)];
  return y;
}

}  // namespace

UNetReference::UNetReference(const UNetConfig& c) : config_(c) {
  const int mc = c.model_channels, temb = c.time_embed_dim();
  param("time_embed.0.weight", {temb, mc});
  param("time_embed.0.bias", {temb});
  param("time_embed.2.weight", {temb, temb});
  param("time_embed.2.bias", {temb});

  auto attention_layer = [&](const std::string& prefix, int ch, int heads_when_per_count) {
    Layer a;
    a.prefix = prefix;
    a.in_ch = a.out_ch = ch;
    a.kind = Kind::Attn;
    // AttentionBlock: num_head_channels (legacy: the configured one) wins over num_heads.
    a.heads = c.num_head_channels == -1 ? heads_when_per_count : ch / c.num_head_channels;
    return a;
  };

  input_blocks_.push_back({Layer{Kind::Conv, "input_blocks.0.0", c.in_channels, mc}});
  std::vector<int> skip_channels{mc};
  int ch = mc, ds = 1;
  for (size_t level = 0; level < c.channel_mult.size(); ++level) {
    const int mult = c.channel_mult[level];
    for (int r = 0; r < c.num_res_blocks; ++r) {
      const std::string p = "input_blocks." + std::to_string(input_blocks_.size()) + ".";
      std::vector<Layer> block{Layer{Kind::Res, p + "0", ch, mult * mc}};
      ch = mult * mc;
      if (contains(c.attention_resolutions, ds)) block.push_back(attention_layer(p + "1", ch, c.num_heads));
      input_blocks_.push_back(block);
      skip_channels.push_back(ch);
    }
    if (level + 1 != c.channel_mult.size()) {
      const std::string p = "input_blocks." + std::to_string(input_blocks_.size()) + ".0";
      Layer d{c.resblock_updown ? Kind::Res : Kind::Down, p, ch, ch};
      d.down = true;
      d.resample_conv = c.conv_resample;
      input_blocks_.push_back({d});
      skip_channels.push_back(ch);
      ds *= 2;
    }
  }
  middle_block_.push_back(Layer{Kind::Res, "middle_block.0", ch, ch});
  if (c.middle_force_spatial_transformer) {
    Layer t{Kind::Transformer, "middle_block.1", ch, ch};
    t.heads = c.num_head_channels == -1 ? c.num_heads : ch / c.num_head_channels;
    t.dim_head = ch / t.heads;
    t.depth = c.transformer_depth;
    t.disable_sa = c.middle_disable_first_sa;
    middle_block_.push_back(t);
  } else {
    middle_block_.push_back(attention_layer("middle_block.1", ch, c.num_heads));
  }
  middle_block_.push_back(Layer{Kind::Res, "middle_block.2", ch, ch});

  const int heads_up = c.num_heads_upsample == -1 ? c.num_heads : c.num_heads_upsample;
  for (size_t level = c.channel_mult.size(); level-- > 0;) {
    const int mult = c.channel_mult[level];
    for (int i = 0; i <= c.num_res_blocks; ++i) {
      const int ich = skip_channels.back();
      skip_channels.pop_back();
      const std::string p = "output_blocks." + std::to_string(output_blocks_.size()) + ".";
      std::vector<Layer> block{Layer{Kind::Res, p + "0", ch + ich, mc * mult}};
      ch = mc * mult;
      if (contains(c.attention_resolutions, ds)) block.push_back(attention_layer(p + "1", ch, heads_up));
      if (level != 0 && i == c.num_res_blocks) {
        Layer u{c.resblock_updown ? Kind::Res : Kind::Up, p + std::to_string(block.size()), ch, ch};
        u.up = true;
        u.resample_conv = c.conv_resample;
        block.push_back(u);
        ds /= 2;
      }
      output_blocks_.push_back(block);
    }
  }
  for (const auto& b : input_blocks_)
    for (const Layer& l : b) add_params(l);
  for (const Layer& l : middle_block_) add_params(l);
  for (const auto& b : output_blocks_)
    for (const Layer& l : b) add_params(l);
  param("out.0.weight", {ch});
  param("out.0.bias", {ch});
  param("out.2.weight", {c.outputs(), mc, 3, 3, 3});
  param("out.2.bias", {c.outputs()});
  // The official state dict lists time_embed first, then the blocks, then out; keep that order.
}

void UNetReference::param(const std::string& name, std::vector<int64_t> shape) { params_.push_back({name, std::move(shape)}); }

void UNetReference::add_params(const Layer& l) {
  const std::string& p = l.prefix;
  const int in = l.in_ch, out = l.out_ch;
  switch (l.kind) {
    case Kind::Conv:
      param(p + ".weight", {out, in, 3, 3, 3});
      param(p + ".bias", {out});
      break;
    case Kind::Res: {
      const int temb = config_.time_embed_dim();
      param(p + ".in_layers.0.weight", {in});
      param(p + ".in_layers.0.bias", {in});
      param(p + ".in_layers.2.weight", {out, in, 3, 3, 3});
      param(p + ".in_layers.2.bias", {out});
      const int e = config_.use_scale_shift_norm ? 2 * out : out;
      param(p + ".emb_layers.1.weight", {e, temb});
      param(p + ".emb_layers.1.bias", {e});
      param(p + ".out_layers.0.weight", {out});
      param(p + ".out_layers.0.bias", {out});
      param(p + ".out_layers.3.weight", {out, out, 3, 3, 3});
      param(p + ".out_layers.3.bias", {out});
      if (out != in) {
        param(p + ".skip_connection.weight", {out, in, 1, 1, 1});
        param(p + ".skip_connection.bias", {out});
      }
      break;
    }
    case Kind::Attn:
      param(p + ".norm.weight", {in});
      param(p + ".norm.bias", {in});
      param(p + ".qkv.weight", {3 * in, in, 1});
      param(p + ".qkv.bias", {3 * in});
      param(p + ".proj_out.weight", {in, in, 1});
      param(p + ".proj_out.bias", {in});
      break;
    case Kind::Transformer: {
      const int inner = l.heads * l.dim_head;
      param(p + ".norm.weight", {in});
      param(p + ".norm.bias", {in});
      param(p + ".proj_in.weight", {inner, in, 1, 1, 1});
      param(p + ".proj_in.bias", {inner});
      for (int b = 0; b < l.depth; ++b) {
        const std::string q = p + ".transformer_blocks." + std::to_string(b) + ".";
        for (const char* attn : {"attn1", "attn2"}) {
          if (l.disable_sa && std::string(attn) == "attn1") continue;
          for (const char* m : {"to_q", "to_k", "to_v"}) param(q + attn + "." + m + ".weight", {inner, inner});
          param(q + attn + ".to_out.0.weight", {inner, inner});
          param(q + attn + ".to_out.0.bias", {inner});
        }
        param(q + "ff.net.0.proj.weight", {8 * inner, inner});
        param(q + "ff.net.0.proj.bias", {8 * inner});
        param(q + "ff.net.2.weight", {inner, 4 * inner});
        param(q + "ff.net.2.bias", {inner});
        for (const char* n : {"norm1", "norm2", "norm3"}) {
          if (l.disable_sa && std::string(n) == "norm1") continue;
          param(q + n + ".weight", {inner});
          param(q + n + ".bias", {inner});
        }
      }
      param(p + ".proj_out.weight", {in, inner, 1, 1, 1});
      param(p + ".proj_out.bias", {in});
      break;
    }
    case Kind::Down:
      if (l.resample_conv) {
        param(p + ".op.weight", {out, in, 3, 3, 3});
        param(p + ".op.bias", {out});
      }
      break;
    case Kind::Up:
      if (l.resample_conv) {
        param(p + ".conv.weight", {out, in, 3, 3, 3});
        param(p + ".conv.bias", {out});
      }
      break;
  }
}

uint64_t UNetReference::parameter_count() const {
  uint64_t n = 0;
  for (const ParamSpec& p : params_) n += static_cast<uint64_t>(CpuTensor::count(p.shape));
  return n;
}

void UNetReference::set_weights(std::map<std::string, CpuTensor> weights) {
  for (const ParamSpec& p : params_) {
    const auto it = weights.find(p.name);
    if (it == weights.end()) throw std::invalid_argument("UNet weights: missing " + p.name);
    if (it->second.shape != p.shape)
      throw std::invalid_argument("UNet weights: " + p.name + " is " + it->second.shape_text() + ", expected " +
                                  CpuTensor(p.shape).shape_text());
  }
  weights_ = std::move(weights);
}

const CpuTensor& UNetReference::w(const std::string& name) const {
  const auto it = weights_.find(name);
  if (it == weights_.end()) throw std::logic_error("UNet reference: no weights set (" + name + ")");
  return it->second;
}

CpuTensor UNetReference::res_block(const Layer& l, const CpuTensor& x_in, const CpuTensor& emb) const {
  const std::string& p = l.prefix;
  CpuTensor x = x_in;
  CpuTensor h = cpu::silu(cpu::group_norm(x, 32, w(p + ".in_layers.0.weight"), w(p + ".in_layers.0.bias"), 1e-5));
  if (l.up) {
    h = cpu::upsample2(h);
    x = cpu::upsample2(x);
  } else if (l.down) {
    h = cpu::avg_pool2(h);
    x = cpu::avg_pool2(x);
  }
  h = cpu::conv3d(h, w(p + ".in_layers.2.weight"), &w(p + ".in_layers.2.bias"));
  const CpuTensor e = cpu::linear(cpu::silu(emb), w(p + ".emb_layers.1.weight"), &w(p + ".emb_layers.1.bias"));
  if (config_.use_scale_shift_norm) {
    h = cpu::group_norm(h, 32, w(p + ".out_layers.0.weight"), w(p + ".out_layers.0.bias"), 1e-5);
    h = cpu::silu(cpu::scale_shift(std::move(h), e));
  } else {
    h = cpu::add_channel_bias(std::move(h), e);
    h = cpu::silu(cpu::group_norm(h, 32, w(p + ".out_layers.0.weight"), w(p + ".out_layers.0.bias"), 1e-5));
  }
  h = cpu::conv3d(h, w(p + ".out_layers.3.weight"), &w(p + ".out_layers.3.bias"));
  if (l.out_ch != l.in_ch) x = cpu::conv3d(x, w(p + ".skip_connection.weight"), &w(p + ".skip_connection.bias"));
  return cpu::add(std::move(x), h);
}

CpuTensor UNetReference::attention_block(const Layer& l, const CpuTensor& x) const {
  const std::string& p = l.prefix;
  const int64_t C = x.dim(1), N = x.per_item() / C, D = C / l.heads;
  const CpuTensor qkv = cpu::conv3d(cpu::group_norm(x, 32, w(p + ".norm.weight"), w(p + ".norm.bias"), 1e-5),
                                    w(p + ".qkv.weight"), &w(p + ".qkv.bias"));
  // q, k, v = qkv.chunk(3, dim=1); heads split as "(h d)".
  const CpuTensor q = split_heads_channels_first(qkv, 0, 3 * C, l.heads, D, N);
  const CpuTensor k = split_heads_channels_first(qkv, C, 3 * C, l.heads, D, N);
  const CpuTensor v = split_heads_channels_first(qkv, 2 * C, 3 * C, l.heads, D, N);
  const CpuTensor a = cpu::attention(q, k, v);  // [B, H, N, D]
  const CpuTensor merged = from_tokens(merge_heads_tokens(a), x.shape);  // "b h n d -> b (h d) n"
  return cpu::add(x, cpu::conv3d(merged, w(p + ".proj_out.weight"), &w(p + ".proj_out.bias")));
}

CpuTensor UNetReference::spatial_transformer(const Layer& l, const CpuTensor& x) const {
  const std::string& p = l.prefix;
  CpuTensor h = cpu::group_norm(x, 32, w(p + ".norm.weight"), w(p + ".norm.bias"), 1e-6);
  h = cpu::conv3d(h, w(p + ".proj_in.weight"), &w(p + ".proj_in.bias"));
  CpuTensor t = to_tokens(h);  // [B, N, inner]
  auto self_attention = [&](const std::string& a, const CpuTensor& in) {
    const CpuTensor q = split_heads_tokens(cpu::linear(in, w(a + ".to_q.weight"), nullptr), l.heads);
    const CpuTensor k = split_heads_tokens(cpu::linear(in, w(a + ".to_k.weight"), nullptr), l.heads);
    const CpuTensor v = split_heads_tokens(cpu::linear(in, w(a + ".to_v.weight"), nullptr), l.heads);
    return cpu::linear(merge_heads_tokens(cpu::attention(q, k, v)), w(a + ".to_out.0.weight"), &w(a + ".to_out.0.bias"));
  };
  for (int b = 0; b < l.depth; ++b) {
    const std::string q = p + ".transformer_blocks." + std::to_string(b) + ".";
    if (!l.disable_sa) t = cpu::add(self_attention(q + "attn1", cpu::layer_norm(t, w(q + "norm1.weight"), w(q + "norm1.bias"))), t);
    t = cpu::add(self_attention(q + "attn2", cpu::layer_norm(t, w(q + "norm2.weight"), w(q + "norm2.bias"))), t);
    // GEGLU feed-forward: proj -> (value, gate) halves of the last axis -> value * gelu(gate) -> linear.
    const CpuTensor proj =
        cpu::linear(cpu::layer_norm(t, w(q + "norm3.weight"), w(q + "norm3.bias")), w(q + "ff.net.0.proj.weight"),
                    &w(q + "ff.net.0.proj.bias"));
    const int64_t two_f = proj.shape.back(), f = two_f / 2, rows = proj.numel() / two_f;
    std::vector<int64_t> gshape = proj.shape;
    gshape.back() = f;
    CpuTensor gate(gshape), value(gshape);
    for (int64_t r = 0; r < rows; ++r)
      for (int64_t i = 0; i < f; ++i) {
        value.data[static_cast<size_t>(r * f + i)] = proj.data[static_cast<size_t>(r * two_f + i)];
        gate.data[static_cast<size_t>(r * f + i)] = proj.data[static_cast<size_t>(r * two_f + f + i)];
      }
    gate = cpu::gelu(std::move(gate));
    for (size_t i = 0; i < value.data.size(); ++i) value.data[i] *= gate.data[i];
    t = cpu::add(cpu::linear(value, w(q + "ff.net.2.weight"), &w(q + "ff.net.2.bias")), t);
  }
  h = from_tokens(t, x.shape);
  return cpu::add(cpu::conv3d(h, w(p + ".proj_out.weight"), &w(p + ".proj_out.bias")), x);
}

CpuTensor UNetReference::run(const Layer& l, const CpuTensor& x, const CpuTensor& emb) const {
  switch (l.kind) {
    case Kind::Conv: return cpu::conv3d(x, w(l.prefix + ".weight"), &w(l.prefix + ".bias"));
    case Kind::Res: return res_block(l, x, emb);
    case Kind::Attn: return attention_block(l, x);
    case Kind::Transformer: return spatial_transformer(l, x);
    case Kind::Down:
      return l.resample_conv ? cpu::conv3d(x, w(l.prefix + ".op.weight"), &w(l.prefix + ".op.bias"), 2, 1)
                             : cpu::avg_pool2(x);
    case Kind::Up: {
      const CpuTensor u = cpu::upsample2(x);
      return l.resample_conv ? cpu::conv3d(u, w(l.prefix + ".conv.weight"), &w(l.prefix + ".conv.bias")) : u;
    }
  }
  throw std::logic_error("UNet reference: unknown layer");
}

CpuTensor UNetReference::forward(const CpuTensor& x, const std::vector<int64_t>& t, const Capture& capture) const {
  if (x.rank() != 5 || x.dim(1) != config_.in_channels)
    throw std::invalid_argument("UNet: input " + x.shape_text() + " is not [B, " + std::to_string(config_.in_channels) +
                                ", X, Y, Z]");
  if (static_cast<int64_t>(t.size()) != x.dim(0))
    throw std::invalid_argument("UNet: " + std::to_string(t.size()) + " timesteps for a batch of " + std::to_string(x.dim(0)));
  check_unet_grid(config_, x.dim(2), x.dim(3), x.dim(4));
  const CpuTensor t_emb = cpu::timestep_embedding(t, config_.model_channels);
  const CpuTensor emb = cpu::linear(cpu::silu(cpu::linear(t_emb, w("time_embed.0.weight"), &w("time_embed.0.bias"))),
                                    w("time_embed.2.weight"), &w("time_embed.2.bias"));
  if (capture) {
    capture("t_emb", t_emb);
    capture("emb", emb);
  }
  std::vector<CpuTensor> hs;
  CpuTensor h = x;
  for (size_t i = 0; i < input_blocks_.size(); ++i) {
    for (const Layer& l : input_blocks_[i]) h = run(l, h, emb);
    if (capture) capture("input_blocks." + std::to_string(i), h);
    hs.push_back(h);
  }
  for (const Layer& l : middle_block_) h = run(l, h, emb);
  if (capture) capture("middle_block", h);
  for (size_t i = 0; i < output_blocks_.size(); ++i) {
    h = cpu::concat_channels(h, hs.back());
    hs.pop_back();
    for (const Layer& l : output_blocks_[i]) h = run(l, h, emb);
    if (capture) capture("output_blocks." + std::to_string(i), h);
  }
  h = cpu::silu(cpu::group_norm(h, 32, w("out.0.weight"), w("out.0.bias"), 1e-5));
  return cpu::conv3d(h, w("out.2.weight"), &w("out.2.bias"));
}

}  // namespace icube::nn
