// The dense diffusion UNet on the GPU; see unet_gpu.h.
#include "nn/unet_gpu.h"

#include "nn/activation_pool.h"

#include "nn/attention.h"
#include "nn/conv3d.h"
#include "nn/elementwise.h"
#include "nn/group_norm.h"
#include "nn/layer_norm.h"
#include "nn/layers_cpu.h"

#include <map>
#include <stdexcept>

namespace icube::nn {

namespace {

using Kind = UNetReference::Layer::Kind;

// A device tensor: a buffer and its shape [B, C, spatial...].
struct GT {
  std::shared_ptr<gpu::Buffer> buf;
  std::vector<int64_t> shape;
  int64_t batch() const { return shape[0]; }
  int64_t channels() const { return shape[1]; }
  int64_t spatial() const {
    int64_t s = 1;
    for (size_t i = 2; i < shape.size(); ++i) s *= shape[i];
    return s;
  }
  uint64_t numel() const { return static_cast<uint64_t>(batch() * channels() * spatial()); }
};

}  // namespace

struct UNetGpu::Impl {
  gpu::Context& ctx;
  UNetReference tree;
  kernels::nn::Conv3d conv;
  kernels::nn::GroupNorm gn;
  kernels::nn::LayerNorm ln;
  kernels::nn::Elementwise ew;
  kernels::nn::Attention attn;
  std::map<std::string, std::unique_ptr<gpu::Buffer>> params;  // packed conv / linear weights, raw vectors
  std::map<std::string, std::vector<int64_t>> param_shapes;
  bool f16_weights = false;  // conv / linear weights packed as fp16
  ActivationPool pool;  // activation memory plan (activation_pool.h)
  std::vector<std::shared_ptr<gpu::Buffer>> alive;  // inputs, kept until the forward ends
  gpu::CommandList* cmd = nullptr;

  Impl(gpu::Context& c, const UNetConfig& cfg)
      : ctx(c), tree(cfg), conv(c), gn(c), ln(c), ew(c), attn(c), pool(c, "unet-activation") {}

  const gpu::Buffer& P(const std::string& name) const {
    const auto it = params.find(name);
    if (it == params.end()) throw std::logic_error("UNetGpu: no parameter " + name);
    return *it->second;
  }
  GT alloc(std::vector<int64_t> shape) {
    GT t;
    t.shape = std::move(shape);
    t.buf = pool.take(std::max<uint64_t>(t.numel(), 1) * 4);
    return t;
  }
  void barrier() { cmd->barrier(gpu::deps::kComputeToCompute); }
  static void dims(const GT& x, uint32_t& sx, uint32_t& sy, uint32_t& sz) {
    if (x.shape.size() == 5) {
      sx = static_cast<uint32_t>(x.shape[2]);
      sy = static_cast<uint32_t>(x.shape[3]);
      sz = static_cast<uint32_t>(x.shape[4]);
    } else {
      sx = static_cast<uint32_t>(x.spatial());
      sy = sz = 1;
    }
  }
  // Convolution (3^3 or 1^3) or linear (a 1x1 convolution on channels-first tokens).
  GT convolve(const GT& x, const std::string& prefix, bool has_bias = true) {
    const std::vector<int64_t>& ws = param_shapes.at(prefix + ".weight");
    const uint32_t k = ws.size() == 5 && ws[2] == 3 ? 3u : 1u;
    std::vector<int64_t> shape = x.shape;
    shape[1] = ws[0];
    GT y = alloc(shape);
    kernels::nn::Conv3dShape s;
    s.batch = static_cast<uint32_t>(x.batch());
    s.in_channels = static_cast<uint32_t>(x.channels());
    s.out_channels = static_cast<uint32_t>(ws[0]);
    dims(x, s.x, s.y, s.z);
    s.kernel = k;
    s.f16_weights = f16_weights;
    conv.record(*cmd, s, *x.buf, P(prefix + ".weight"), has_bias ? &P(prefix + ".bias") : nullptr, *y.buf);
    barrier();
    return y;
  }
  GT group_norm(const GT& x, const std::string& prefix, float eps, bool silu, const GT* modulation = nullptr) {
    GT y = alloc(x.shape);
    kernels::nn::GroupNormShape s;
    s.batch = static_cast<uint32_t>(x.batch());
    s.channels = static_cast<uint32_t>(x.channels());
    s.groups = 32;
    s.spatial = static_cast<uint64_t>(x.spatial());
    s.eps = eps;
    s.silu = silu;
    s.modulate = modulation != nullptr;
    GT scratch = alloc({static_cast<int64_t>(kernels::nn::GroupNorm::scratch_bytes(s) / 4 + 1), 1});
    gn.record(*cmd, s, *x.buf, P(prefix + ".weight"), P(prefix + ".bias"), modulation ? modulation->buf.get() : nullptr,
              *scratch.buf, *y.buf);
    barrier();
    return y;
  }
  GT layer_norm(const GT& x, const std::string& prefix) {
    GT y = alloc(x.shape);
    ln.record(*cmd, {static_cast<uint32_t>(x.batch()), static_cast<uint32_t>(x.channels()), static_cast<uint64_t>(x.spatial()), 1e-5f},
              *x.buf, P(prefix + ".weight"), P(prefix + ".bias"), *y.buf);
    barrier();
    return y;
  }
  GT silu(const GT& x) {
    GT y = alloc(x.shape);
    ew.silu(*cmd, *x.buf, x.numel(), *y.buf);
    barrier();
    return y;
  }
  GT add(const GT& a, const GT& b) {
    GT y = alloc(a.shape);
    ew.add(*cmd, *a.buf, *b.buf, a.numel(), *y.buf);
    barrier();
    return y;
  }
  GT resample(const GT& x, bool up) {
    uint32_t sx, sy, sz;
    dims(x, sx, sy, sz);
    const uint32_t planes = static_cast<uint32_t>(x.batch() * x.channels());
    std::vector<int64_t> shape = x.shape;
    for (size_t i = 2; i < 5; ++i) shape[i] = up ? shape[i] * 2 : shape[i] / 2;
    GT y = alloc(shape);
    if (up) ew.upsample2(*cmd, *x.buf, planes, sx, sy, sz, *y.buf);
    else ew.avg_pool2(*cmd, *x.buf, planes, sx, sy, sz, *y.buf);
    barrier();
    return y;
  }
  GT tokens_of(const GT& x) {  // the same buffer viewed as [B, C, N]
    GT t = x;
    t.shape = {x.batch(), x.channels(), x.spatial()};
    return t;
  }
  GT concat(const GT& a, const GT& b) {
    std::vector<int64_t> shape = a.shape;
    shape[1] = a.channels() + b.channels();
    GT y = alloc(shape);
    cmd->barrier(gpu::deps::kComputeToTransfer);
    const uint64_t S = static_cast<uint64_t>(a.spatial()), ca = static_cast<uint64_t>(a.channels()),
                   cb = static_cast<uint64_t>(b.channels());
    for (int64_t n = 0; n < a.batch(); ++n) {
      const uint64_t nb = static_cast<uint64_t>(n);
      cmd->copy_buffer(a.buf->binding(nb * ca * S * 4, ca * S * 4), y.buf->binding(nb * (ca + cb) * S * 4, ca * S * 4));
      cmd->copy_buffer(b.buf->binding(nb * cb * S * 4, cb * S * 4), y.buf->binding((nb * (ca + cb) + ca) * S * 4, cb * S * 4));
    }
    cmd->barrier(gpu::deps::kTransferToCompute);
    return y;
  }

  GT res_block(const UNetReference::Layer& l, GT x, const GT& emb_silu) {
    const std::string& p = l.prefix;
    GT h = group_norm(x, p + ".in_layers.0", 1e-5f, true);
    if (l.up || l.down) {
      h = resample(h, l.up);
      x = resample(x, l.up);
    }
    h = convolve(h, p + ".in_layers.2");
    const GT e = convolve(emb_silu, p + ".emb_layers.1");  // [B, 2C, 1] = the (scale, shift) rows
    h = group_norm(h, p + ".out_layers.0", 1e-5f, true, &e);
    h = convolve(h, p + ".out_layers.3");
    const GT skip = l.out_ch != l.in_ch ? convolve(x, p + ".skip_connection") : x;
    return add(skip, h);
  }
  GT attention_block(const UNetReference::Layer& l, const GT& x) {
    const std::string& p = l.prefix;
    const GT qkv = convolve(tokens_of(group_norm(x, p + ".norm", 1e-5f, false)), p + ".qkv");
    GT a = alloc({x.batch(), x.channels(), x.spatial()});
    const kernels::nn::AttentionShape s{static_cast<uint32_t>(x.batch()), static_cast<uint32_t>(l.heads),
                                        static_cast<uint32_t>(x.channels() / l.heads), static_cast<uint64_t>(x.spatial())};
    attn.record_qkv(*cmd, s, *qkv.buf, *a.buf);
    barrier();
    GT o = convolve(a, p + ".proj_out");
    o.shape = x.shape;
    return add(x, o);
  }
  GT self_attention(const GT& t, const std::string& a, int heads) {
    const GT q = convolve(t, a + ".to_q", false), k = convolve(t, a + ".to_k", false), v = convolve(t, a + ".to_v", false);
    GT o = alloc(q.shape);
    attn.record(*cmd, {static_cast<uint32_t>(q.batch()), static_cast<uint32_t>(heads),
                       static_cast<uint32_t>(q.channels() / heads), static_cast<uint64_t>(q.spatial())},
                *q.buf, *k.buf, *v.buf, *o.buf);
    barrier();
    return convolve(o, a + ".to_out.0");
  }
  GT spatial_transformer(const UNetReference::Layer& l, const GT& x) {
    const std::string& p = l.prefix;
    GT h = convolve(tokens_of(group_norm(x, p + ".norm", 1e-6f, false)), p + ".proj_in");
    for (int b = 0; b < l.depth; ++b) {
      const std::string q = p + ".transformer_blocks." + std::to_string(b) + ".";
      if (!l.disable_sa) h = add(self_attention(layer_norm(h, q + "norm1"), q + "attn1", l.heads), h);
      h = add(self_attention(layer_norm(h, q + "norm2"), q + "attn2", l.heads), h);
      const GT proj = convolve(layer_norm(h, q + "norm3"), q + "ff.net.0.proj");
      GT g = alloc({proj.batch(), proj.channels() / 2, proj.spatial()});
      ew.geglu(*cmd, *proj.buf, static_cast<uint32_t>(proj.batch()), static_cast<uint32_t>(proj.channels() / 2),
               static_cast<uint64_t>(proj.spatial()), *g.buf);
      barrier();
      h = add(convolve(g, q + "ff.net.2"), h);
    }
    GT o = convolve(h, p + ".proj_out");
    o.shape = x.shape;
    return add(o, x);
  }
  GT run(const UNetReference::Layer& l, const GT& x, const GT& emb_silu) {
    switch (l.kind) {
      case Kind::Conv: return convolve(x, l.prefix);
      case Kind::Res: return res_block(l, x, emb_silu);
      case Kind::Attn: return attention_block(l, x);
      case Kind::Transformer: return spatial_transformer(l, x);
      case Kind::Up: return l.resample_conv ? convolve(resample(x, true), l.prefix + ".conv") : resample(x, true);
      case Kind::Down:
        if (l.resample_conv) throw std::invalid_argument("UNetGpu: strided Downsample convolutions are not implemented");
        return resample(x, false);
    }
    throw std::logic_error("UNetGpu: unknown layer");
  }
};

UNetGpu::UNetGpu(gpu::Context& ctx, const UNetConfig& config, const std::map<std::string, CpuTensor>& weights,
                 Precision precision)
    : impl_(std::make_unique<Impl>(ctx, config)) {
  impl_->f16_weights = precision == Precision::F16Weights;
  if (!config.use_scale_shift_norm)
    throw std::invalid_argument("UNetGpu: use_scale_shift_norm = false is implemented on the CPU reference only");
  for (const ParamSpec& p : impl_->tree.parameters()) {
    const auto it = weights.find(p.name);
    if (it == weights.end() || it->second.shape != p.shape) throw std::invalid_argument("UNetGpu: missing or misshapen " + p.name);
    const std::vector<float>& data = it->second.data;
    if (p.shape.size() >= 2) {  // a convolution or linear weight [Co, Ci, (k, k, k | 1)]
      const uint32_t k = p.shape.size() == 5 && p.shape[2] == 3 ? 3u : 1u;
      const auto co = static_cast<uint32_t>(p.shape[0]), ci = static_cast<uint32_t>(p.shape[1]);
      impl_->params[p.name] = std::make_unique<gpu::Buffer>(
          impl_->f16_weights ? gpu::upload_vector(ctx, kernels::nn::pack_conv3d_weights_f16(data, co, ci, k), p.name)
                             : gpu::upload_vector(ctx, kernels::nn::pack_conv3d_weights(data, co, ci, k), p.name));
    } else {
      impl_->params[p.name] = std::make_unique<gpu::Buffer>(gpu::upload_vector(ctx, data, p.name));
    }
    weight_bytes_ += impl_->params[p.name]->size();
    impl_->param_shapes[p.name] = p.shape;
  }
}

UNetGpu::~UNetGpu() = default;

void UNetGpu::set_max_binding_bytes(uint64_t bytes) {
  impl_->conv.set_max_binding_bytes(bytes);
  impl_->gn.set_max_binding_bytes(bytes);
  impl_->ew.set_max_binding_bytes(bytes);
}

CpuTensor UNetGpu::forward(const CpuTensor& x, const std::vector<int64_t>& t, const UNetReference::Capture& capture) {
  Impl& m = *impl_;
  const UNetConfig& c = m.tree.config();
  if (x.rank() != 5 || x.dim(1) != c.in_channels)
    throw std::invalid_argument("UNet: input " + x.shape_text() + " is not [B, " + std::to_string(c.in_channels) + ", X, Y, Z]");
  if (static_cast<int64_t>(t.size()) != x.dim(0))
    throw std::invalid_argument("UNet: " + std::to_string(t.size()) + " timesteps for a batch of " + std::to_string(x.dim(0)));
  check_unet_grid(c, x.dim(2), x.dim(3), x.dim(4));
  m.alive.clear();
  m.pool.reset();
  const CpuTensor t_emb = cpu::timestep_embedding(t, c.model_channels);
  auto upload = [&](const CpuTensor& v, std::vector<int64_t> shape) {
    GT g;
    g.shape = std::move(shape);
    g.buf = std::make_shared<gpu::Buffer>(gpu::upload_vector(m.ctx, v.data, "unet-input"));
    m.alive.push_back(g.buf);
    return g;
  };
  const GT xin = upload(x, x.shape), temb = upload(t_emb, {x.dim(0), c.model_channels, 1});
  std::vector<std::pair<std::string, GT>> captured;
  GT out;
  m.ctx.submit_and_wait([&](gpu::CommandList& cmd) {
    m.cmd = &cmd;
    const GT emb = m.convolve(m.silu(m.convolve(temb, "time_embed.0")), "time_embed.2");
    const GT emb_silu = m.silu(emb);  // every ResBlock's emb_layers start with SiLU
    if (capture) captured.emplace_back("emb", emb);
    std::vector<GT> hs;
    GT h = xin;
    for (size_t i = 0; i < m.tree.input_blocks().size(); ++i) {
      for (const auto& l : m.tree.input_blocks()[i]) h = m.run(l, h, emb_silu);
      if (capture) captured.emplace_back("input_blocks." + std::to_string(i), h);
      hs.push_back(h);
    }
    for (const auto& l : m.tree.middle_block()) h = m.run(l, h, emb_silu);
    if (capture) captured.emplace_back("middle_block", h);
    for (size_t i = 0; i < m.tree.output_blocks().size(); ++i) {
      h = m.concat(h, hs.back());
      hs.pop_back();
      for (const auto& l : m.tree.output_blocks()[i]) h = m.run(l, h, emb_silu);
      if (capture) captured.emplace_back("output_blocks." + std::to_string(i), h);
    }
    out = m.convolve(m.group_norm(h, "out.0", 1e-5f, true), "out.2");
    cmd.barrier(gpu::deps::kComputeToTransfer);
    m.cmd = nullptr;
  });
  activation_bytes_ = m.pool.bytes();
  auto download = [&](const GT& g) {
    CpuTensor r(g.shape);
    r.data = gpu::download_vector<float>(m.ctx, *g.buf, static_cast<size_t>(g.numel()));
    return r;
  };
  if (capture) {
    capture("t_emb", t_emb);
    for (const auto& [name, g] : captured) {
      CpuTensor v = download(g);
      if (name == "emb") v.shape = {x.dim(0), v.dim(1)};
      capture(name, v);
    }
  }
  CpuTensor y = download(out);
  captured.clear();
  out = GT{};
  m.alive.clear();
  m.pool.reset();
  return y;
}

}  // namespace icube::nn
