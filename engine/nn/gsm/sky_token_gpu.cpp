// The GSM's sky token on the GPU; see sky_token_gpu.h.
#include "nn/gsm/sky_token_gpu.h"

#include "gpu/buffer.h"
#include "gpu/context.h"

#include <memory>
#include <stdexcept>
#include <vector>

namespace icube::nn {

namespace {

const std::string kLayers = "skybox.transformer.layers.";

// PyTorch's nn.TransformerEncoderLayer (post-norm, GELU, eval) on tokens [1, E, n].
DeviceTensor encoder_layer_gpu(LayerRecorder& L, const SkyConfig& c, const std::string& p, const DeviceTensor& x) {
  const DeviceTensor context = L.attention_qkv(L.conv(x, p + "self_attn.in_proj"), static_cast<uint32_t>(c.heads));
  const DeviceTensor h1 = L.layer_norm(L.add(x, L.conv(context, p + "self_attn.out_proj")), p + "norm1", 1e-5f);
  const DeviceTensor ff = L.conv(L.gelu(L.conv(h1, p + "linear1")), p + "linear2");
  return L.layer_norm(L.add(h1, ff), p + "norm2", 1e-5f);
}

CpuTensor download(gpu::Context& ctx, const DeviceTensor& t) {
  return CpuTensor(t.shape, gpu::download_vector<float>(ctx, *t.buf, t.numel()));
}

}  // namespace

void add_sky_gpu_tensors(const GsmWeights& w, std::map<std::string, CpuTensor>& tensors) {
  for (const auto& [name, t] : w.tensors) {
    const std::string suffix = "self_attn.in_proj_weight";
    if (name.rfind(kLayers, 0) != 0 || name.size() < suffix.size() ||
        name.compare(name.size() - suffix.size(), suffix.size(), suffix) != 0)
      continue;
    const std::string p = name.substr(0, name.size() - suffix.size()) + "self_attn.";
    tensors[p + "in_proj.weight"] = t;
    tensors[p + "in_proj.bias"] = w.at(p + "in_proj_bias");
  }
}

CpuTensor sky_tokens_gpu(LayerRecorder& L, const SkyConfig& c, const GsmWeights& w, const GsmInputs& in,
                         const DeviceTensor& images, GsmTrace* trace) {
  gpu::Context& ctx = L.context();
  const int64_t E = c.embed_dim;
  const auto P = static_cast<uint32_t>(c.patch_size);
  // The patch embedding on the device.
  DeviceTensor patches;
  ctx.submit_and_wait([&](gpu::CommandList& cmd) {
    L.begin(cmd);
    patches = L.conv2d(images, "skybox.patch_embedder", P, 0);
    L.end();
  });
  // The encoder inputs on the host.
  const SkyTokenInputs ti = sky_token_inputs(c, w, in, download(ctx, patches), trace);
  patches = {};
  // The encoder, every batch element in one command list (`inputs` keeps the uploads alive until it ran).
  std::vector<DeviceTensor> inputs;
  for (const CpuTensor& t : ti.tokens_in) {
    const int64_t n = t.dim(0);
    std::vector<float> channel_major(static_cast<size_t>(n * E));
    for (int64_t i = 0; i < n; ++i)
      for (int64_t e = 0; e < E; ++e)
        channel_major[static_cast<size_t>(e * n + i)] = t.data[static_cast<size_t>(i * E + e)];
    inputs.push_back({std::make_shared<gpu::Buffer>(gpu::upload_vector(ctx, channel_major, "gsm-sky-tokens")), {1, E, n}});
  }
  std::vector<DeviceTensor> xs = inputs;
  ctx.submit_and_wait([&](gpu::CommandList& cmd) {
    L.begin(cmd);
    for (DeviceTensor& x : xs)
      for (int l = 0; l < c.layers; ++l) x = encoder_layer_gpu(L, c, kLayers + std::to_string(l) + ".", x);
    L.end();
  });
  CpuTensor tokens({in.batch, E});
  for (size_t b = 0; b < xs.size(); ++b) {
    const CpuTensor y = download(ctx, xs[b]);  // [1, E, n]
    const int64_t n = y.dim(2);
    for (int64_t e = 0; e < E; ++e) tokens.data[static_cast<size_t>(static_cast<int64_t>(b) * E + e)] = y.data[static_cast<size_t>(e * n)];
    if (trace) {
      CpuTensor out({n, E});
      for (int64_t i = 0; i < n; ++i)
        for (int64_t e = 0; e < E; ++e) out.data[static_cast<size_t>(i * E + e)] = y.data[static_cast<size_t>(e * n + i)];
      trace_put(trace, "sky.tokens_out.b" + std::to_string(b), out);
    }
  }
  return tokens;
}

}  // namespace icube::nn
