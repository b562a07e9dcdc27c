// The dense diffusion UNet on the GPU; see unet_gpu.h.
#include "nn/unet_gpu.h"

#include "nn/layer_recorder.h"
#include "nn/timestep_embedding.h"
#include "nn/parameter_store.h"

#include <map>
#include <stdexcept>

namespace icube::nn {

namespace {

using Kind = UNetReference::Layer::Kind;
using GT = DeviceTensor;

}  // namespace

struct UNetGpu::Impl {
  gpu::Context& ctx;
  UNetReference tree;
  ParameterStore params;
  LayerRecorder L;
  std::vector<std::shared_ptr<gpu::Buffer>> alive;  // inputs, kept until the forward ends

  Impl(gpu::Context& c, const UNetConfig& cfg, const std::map<std::string, CpuTensor>& weights, NetworkPrecision precision)
      : ctx(c), tree(cfg), params(c, tree.parameters(), weights, options(f16_weights(precision))), L(c, params, "unet-activation") {
    L.set_f16_conv_operands(f16_conv_operands(precision));
  }

  static ParameterStoreOptions options(bool f16) {
    ParameterStoreOptions o;
    o.network = "the UNet";
    o.f16_matrices = f16;
    return o;
  }

  GT res_block(const UNetReference::Layer& l, GT x, const GT& emb_silu) {
    const std::string& p = l.prefix;
    // An up/down block resamples the normalised tensor before its convolution: that output stays fp32.
    GT h = L.group_norm(x, p + ".in_layers.0", {32, 1e-5f, true, nullptr, l.up || l.down});
    if (l.up || l.down) {
      h = L.resample(h, l.up);
      x = L.resample(x, l.up);
    }
    h = L.conv(h, p + ".in_layers.2");
    const GT e = L.conv(emb_silu, p + ".emb_layers.1");  // [B, 2C, 1] = the (scale, shift) rows
    h = L.group_norm(h, p + ".out_layers.0", {32, 1e-5f, true, &e});
    h = L.conv(h, p + ".out_layers.3");
    const GT skip = l.out_ch != l.in_ch ? L.conv(x, p + ".skip_connection") : x;
    return L.add(skip, h);
  }
  GT attention_block(const UNetReference::Layer& l, const GT& x) {
    const std::string& p = l.prefix;
    const GT qkv = L.conv(LayerRecorder::tokens(L.group_norm(x, p + ".norm", {32, 1e-5f})), p + ".qkv");
    GT o = L.conv(L.attention_qkv(qkv, static_cast<uint32_t>(l.heads)), p + ".proj_out");
    o.shape = x.shape;
    return L.add(x, o);
  }
  GT self_attention(const GT& t, const std::string& a, int heads) {
    const GT q = L.conv(t, a + ".to_q"), k = L.conv(t, a + ".to_k"), v = L.conv(t, a + ".to_v");
    return L.conv(L.attention(q, k, v, static_cast<uint32_t>(heads)), a + ".to_out.0");
  }
  GT spatial_transformer(const UNetReference::Layer& l, const GT& x) {
    const std::string& p = l.prefix;
    GT h = L.conv(LayerRecorder::tokens(L.group_norm(x, p + ".norm", {32, 1e-6f})), p + ".proj_in");
    for (int b = 0; b < l.depth; ++b) {
      const std::string q = p + ".transformer_blocks." + std::to_string(b) + ".";
      if (!l.disable_sa) h = L.add(self_attention(L.layer_norm(h, q + "norm1", 1e-5f), q + "attn1", l.heads), h);
      h = L.add(self_attention(L.layer_norm(h, q + "norm2", 1e-5f), q + "attn2", l.heads), h);
      const GT g = L.geglu(L.conv(L.layer_norm(h, q + "norm3", 1e-5f), q + "ff.net.0.proj"));
      h = L.add(L.conv(g, q + "ff.net.2"), h);
    }
    GT o = L.conv(h, p + ".proj_out");
    o.shape = x.shape;
    return L.add(o, x);
  }
  GT run(const UNetReference::Layer& l, const GT& x, const GT& emb_silu) {
    switch (l.kind) {
      case Kind::Conv: return L.conv(x, l.prefix);
      case Kind::Res: return res_block(l, x, emb_silu);
      case Kind::Attn: return attention_block(l, x);
      case Kind::Transformer: return spatial_transformer(l, x);
      case Kind::Up: return l.resample_conv ? L.conv(L.resample(x, true), l.prefix + ".conv") : L.resample(x, true);
      case Kind::Down:
        if (l.resample_conv) throw std::invalid_argument("UNetGpu: strided Downsample convolutions are not implemented");
        return L.resample(x, false);
    }
    throw std::logic_error("UNetGpu: unknown layer");
  }

  // Checks x's shape and the timesteps against the model.
  void check_input(const std::vector<int64_t>& x_shape, const std::vector<int64_t>& t) const {
    const UNetConfig& c = tree.config();
    if (x_shape.size() != 5 || x_shape[1] != c.in_channels)
      throw std::invalid_argument("UNet: input " + shape_text(x_shape) + " is not [B, " + std::to_string(c.in_channels) +
                                  ", X, Y, Z]");
    if (static_cast<int64_t>(t.size()) != x_shape[0])
      throw std::invalid_argument("UNet: " + std::to_string(t.size()) + " timesteps for a batch of " + std::to_string(x_shape[0]));
    check_unet_grid(c, x_shape[2], x_shape[3], x_shape[4]);
  }
  GT upload(const std::vector<float>& v, std::vector<int64_t> shape) {
    GT g{std::make_shared<gpu::Buffer>(gpu::upload_vector(ctx, v, "unet-input")), std::move(shape)};
    alive.push_back(g.buf);
    return g;
  }
  // Records the whole forward of xin (timestep embedding t_emb [B, model_channels, 1]) into `cmd`; block
  // outputs go to `captured` when it is given.
  GT record(gpu::CommandList& cmd, const GT& xin, const GT& temb, std::vector<std::pair<std::string, GT>>* captured) {
    L.begin(cmd);
    const GT emb = L.conv(L.silu(L.conv(temb, "time_embed.0")), "time_embed.2");
    const GT emb_silu = L.silu(emb);  // every ResBlock's emb_layers start with SiLU
    if (captured) captured->emplace_back("emb", emb);
    std::vector<GT> hs;
    GT h = xin;
    for (size_t i = 0; i < tree.input_blocks().size(); ++i) {
      for (const auto& l : tree.input_blocks()[i]) h = run(l, h, emb_silu);
      if (captured) captured->emplace_back("input_blocks." + std::to_string(i), h);
      hs.push_back(h);
    }
    for (const auto& l : tree.middle_block()) h = run(l, h, emb_silu);
    if (captured) captured->emplace_back("middle_block", h);
    for (size_t i = 0; i < tree.output_blocks().size(); ++i) {
      h = L.concat(h, hs.back());
      hs.pop_back();
      for (const auto& l : tree.output_blocks()[i]) h = run(l, h, emb_silu);
      if (captured) captured->emplace_back("output_blocks." + std::to_string(i), h);
    }
    const GT out = L.conv(L.group_norm(h, "out.0", {32, 1e-5f, true}), "out.2");
    L.end();
    return out;
  }
};

UNetGpu::UNetGpu(gpu::Context& ctx, const UNetConfig& config, const std::map<std::string, CpuTensor>& weights,
                 Precision precision) {
  if (!config.use_scale_shift_norm)
    throw std::invalid_argument("UNetGpu: use_scale_shift_norm = false is implemented on the CPU reference only");
  impl_ = std::make_unique<Impl>(ctx, config, weights, precision);
  weight_bytes_ = impl_->params.device_bytes();
}

UNetGpu::~UNetGpu() = default;

void UNetGpu::set_max_binding_bytes(uint64_t bytes) { impl_->L.set_max_binding_bytes(bytes); }

CpuTensor UNetGpu::forward(const CpuTensor& x, const std::vector<int64_t>& t, const UNetReference::Capture& capture) {
  Impl& m = *impl_;
  const UNetConfig& c = m.tree.config();
  m.check_input(x.shape, t);
  m.alive.clear();
  m.L.pool().reset();
  m.L.reset_matmul_flops();
  const CpuTensor t_emb = cpu::timestep_embedding(t, c.model_channels);
  const GT xin = m.upload(x.data, x.shape), temb = m.upload(t_emb.data, {x.dim(0), c.model_channels, 1});
  std::vector<std::pair<std::string, GT>> captured;
  GT out;
  m.ctx.submit_and_wait([&](gpu::CommandList& cmd) {
    out = m.record(cmd, xin, temb, capture ? &captured : nullptr);
    cmd.barrier(gpu::deps::kComputeToTransfer);
  });
  activation_bytes_ = m.L.pool().bytes();
  matmul_flops_ = m.L.matmul_flops();
  auto download = [&](const GT& g) {
    CpuTensor r(g.shape);
    if (g.f16) throw std::logic_error("UNetGpu: a captured tensor is fp16 (only norm outputs are)");
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
  m.L.pool().reset();
  return y;
}

void UNetGpu::forward(const gpu::Buffer& x, const std::vector<int64_t>& x_shape, const std::vector<int64_t>& t,
                      const gpu::Buffer& y) {
  Impl& m = *impl_;
  const UNetConfig& c = m.tree.config();
  m.check_input(x_shape, t);
  const GT xin = GT::borrow(x, x_shape);
  std::vector<int64_t> y_shape = x_shape;
  y_shape[1] = c.out_channels;
  const uint64_t y_bytes = GT{nullptr, y_shape, false}.bytes();
  if (x.size() < xin.bytes() || y.size() < y_bytes)
    throw std::invalid_argument("UNet: device buffers of " + std::to_string(x.size()) + " and " + std::to_string(y.size()) +
                                " bytes for an input of " + std::to_string(xin.bytes()) + " and an output of " +
                                std::to_string(y_bytes));
  m.alive.clear();
  m.L.pool().reset();
  m.L.reset_matmul_flops();
  const GT temb = m.upload(cpu::timestep_embedding(t, c.model_channels).data, {x_shape[0], c.model_channels, 1});
  m.ctx.submit_and_wait([&](gpu::CommandList& cmd) {
    const GT out = m.record(cmd, xin, temb, nullptr);
    cmd.barrier(gpu::deps::kComputeToTransfer);
    cmd.copy_buffer(out.buf->binding(0, y_bytes), y.binding(0, y_bytes));
  });
  activation_bytes_ = m.L.pool().bytes();
  matmul_flops_ = m.L.matmul_flops();
  m.alive.clear();
  m.L.pool().reset();
}

}  // namespace icube::nn
