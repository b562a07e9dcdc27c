// x-unet's XUnet (frame kernel 1) on the GPU; see xunet_gpu.h.
#include "nn/gsm/xunet_gpu.h"

#include "kernels/nn/batch_norm.h"
#include "kernels/nn/conv2d.h"
#include "kernels/nn/conv_transpose2d.h"
#include "kernels/nn/rms_norm.h"
#include "scene/input_error.h"

#include <bit>
#include <cctype>
#include <stdexcept>
#include <string>
#include <vector>

namespace icube::nn {

namespace {

uint32_t u32(int64_t v) { return static_cast<uint32_t>(v); }

// Upsample: ConvTranspose3d kernel (1, 4, 4), stride (1, 2, 2), padding (0, 1, 1).
constexpr uint32_t kUpKernel = 4, kUpStride = 2, kUpPadding = 1;

// ---- weight forms ------------------------------------------------------------------------------------

bool starts_with(const std::string& s, const std::string& head) { return s.compare(0, head.size(), head) == 0; }
bool ends_with(const std::string& s, const std::string& tail) {
  return s.size() >= tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
}

// `rel` is head + a stage number + tail.
bool staged(const std::string& rel, const std::string& head, const std::string& tail) {
  if (rel.size() <= head.size() + tail.size() || !starts_with(rel, head) || !ends_with(rel, tail)) return false;
  for (size_t i = head.size(); i < rel.size() - tail.size(); ++i)
    if (!std::isdigit(static_cast<unsigned char>(rel[i]))) return false;
  return true;
}

bool is_upsample_weight(const std::string& rel) { return rel == "mid_upsample.weight" || staged(rel, "ups.", ".3.weight"); }
bool is_downsample_weight(const std::string& rel) { return staged(rel, "downs.", ".3.1.weight"); }

// ---- layers ------------------------------------------------------------------------------------------

const std::vector<int64_t>& shape_of(LayerRecorder& L, const std::string& name) { return L.params().shape(name); }

[[noreturn]] void fail(const std::string& what) { throw std::invalid_argument("x-unet gpu: " + what); }

// Conv with an odd square kernel, "same" padding (weight <m>.weight squeezed to 2-D), bias when present.
DeviceTensor conv(LayerRecorder& L, const DeviceTensor& x, const std::string& m) {
  const std::vector<int64_t>& ws = shape_of(L, m + ".weight");
  if (ws.size() != 4 || ws[2] != ws[3] || ws[2] % 2 == 0)
    fail(m + ".weight " + shape_text(ws) + " is not an odd square 2-D kernel (add_xunet_gpu_tensors squeezes it)");
  return L.conv2d(x, m, 1, u32(ws[2] / 2));
}

// RMSNorm over channels (gamma at <norm>weight) then SiLU, in place.
void rms_norm_silu(LayerRecorder& L, const DeviceTensor& x, const std::string& norm) {
  if (shape_of(L, norm + "weight") != std::vector<int64_t>{x.channels()})
    fail(norm + "weight " + shape_text(shape_of(L, norm + "weight")) + " does not fit " + shape_text(x.shape));
  kernels::nn::RmsNormShape s;
  s.batch = u32(x.batch());
  s.channels = u32(x.channels());
  s.plane = static_cast<uint64_t>(x.spatial());
  s.eps = 1e-12f;
  s.silu = true;
  kernels::nn::RmsNorm op(L.cmd().context());
  op.record(L.cmd(), s, *x.buf, L.params().buffer(norm + "weight"), *x.buf);
  L.barrier();
}

// Block: conv 3x3 -> RMSNorm -> SiLU.
DeviceTensor block(LayerRecorder& L, const DeviceTensor& x, const std::string& p) {
  DeviceTensor h = conv(L, x, p + "proj");
  rms_norm_silu(L, h, p + "norm.");
  return h;
}

// ResnetBlock: block2(block1(x)) + res_conv(x) (identity when the width is kept).
DeviceTensor resnet_block(LayerRecorder& L, const DeviceTensor& x, const std::string& p) {
  const DeviceTensor h = block(L, block(L, x, p + "block1."), p + "block2.");
  return L.add(h, L.params().has(p + "res_conv.weight") ? conv(L, x, p + "res_conv") : x);
}

// Downsample: space-to-depth + 1x1 conv = a 2x2 stride-2 conv with the rearranged weight.
DeviceTensor downsample(LayerRecorder& L, const DeviceTensor& x, const std::string& m) {
  const std::string weight = m + ".space_to_depth_weight";
  const std::vector<int64_t>& ws = shape_of(L, weight);
  if (ws.size() != 4 || ws[1] != x.channels() || ws[2] != 2 || ws[3] != 2)
    fail(weight + " " + shape_text(ws) + " does not fit " + shape_text(x.shape));
  kernels::nn::Conv2dShape s;
  s.batch = u32(x.batch());
  s.in_channels = u32(x.channels());
  s.out_channels = u32(ws[0]);
  s.height = u32(x.shape[2]);
  s.width = u32(x.shape[3]);
  s.kernel_h = s.kernel_w = 2;
  s.stride = 2;
  s.padding = 0;
  DeviceTensor y = L.alloc({x.batch(), ws[0], s.out_height(), s.out_width()});
  kernels::nn::Conv2d op(L.cmd().context());
  op.record(L.cmd(), s, *x.buf, L.params().buffer(weight), &L.params().buffer(m + ".bias"), *y.buf);
  L.barrier();
  return y;
}

// Upsample: ConvTranspose 4x4, stride 2, padding 1 (packed weight <m>.transposed_weight, bias <m>.bias).
DeviceTensor upsample(LayerRecorder& L, const DeviceTensor& x, const std::string& m) {
  const std::vector<int64_t>& bs = shape_of(L, m + ".bias");
  const int64_t co = bs.empty() ? 0 : bs[0];
  const int64_t packed = x.channels() * kUpKernel * kUpKernel * static_cast<int64_t>(gpu::align_up(static_cast<uint64_t>(co), 8));
  if (bs.size() != 1 || shape_of(L, m + ".transposed_weight") != std::vector<int64_t>{packed})
    fail(m + ".transposed_weight " + shape_text(shape_of(L, m + ".transposed_weight")) + " is not a packed 4x4 transposed conv of " +
         shape_text(x.shape) + " to " + std::to_string(co) + " channels");
  kernels::nn::ConvTranspose2dShape s;
  s.batch = u32(x.batch());
  s.in_channels = u32(x.channels());
  s.out_channels = u32(co);
  s.height = u32(x.shape[2]);
  s.width = u32(x.shape[3]);
  s.kernel_h = s.kernel_w = kUpKernel;
  s.stride = kUpStride;
  s.padding = kUpPadding;
  DeviceTensor y = L.alloc({x.batch(), co, s.out_height(), s.out_width()});
  kernels::nn::ConvTranspose2d op(L.cmd().context());
  op.record(L.cmd(), s, *x.buf, L.params().buffer(m + ".transposed_weight"), &L.params().buffer(m + ".bias"), *y.buf);
  L.barrier();
  return y;
}

// n floats of `value`, written in command order (fill_buffer).
DeviceTensor constant(LayerRecorder& L, int64_t n, float value) {
  DeviceTensor t = L.alloc({1, n});  // DeviceTensor shapes are [B, C, ...]
  L.cmd().barrier(gpu::deps::kComputeToTransfer);  // the pooled buffer may still be read by earlier work
  L.cmd().fill_buffer(t.buf->binding(0, static_cast<uint64_t>(n) * 4), std::bit_cast<uint32_t>(value));
  L.cmd().barrier(gpu::deps::kTransferToCompute);
  return t;
}

// x * s (the skip connection's scale) as a channel affine with a zero shift.
DeviceTensor scaled(LayerRecorder& L, const DeviceTensor& x, double s) {
  const DeviceTensor scale = constant(L, x.channels(), static_cast<float>(s)), shift = constant(L, x.channels(), 0.0f);
  DeviceTensor y = L.alloc(x.shape);
  kernels::nn::BatchNorm op(L.cmd().context());
  op.record(L.cmd(), {u32(x.batch()), u32(x.channels()), static_cast<uint64_t>(x.spatial())}, *x.buf, *scale.buf, *shift.buf,
            *y.buf);
  L.barrier();
  return y;
}

// Attention with its own residual: x + to_out(attention(to_qkv(LayerNorm(x)))).
DeviceTensor mid_attention(LayerRecorder& L, const XUnetConfig& c, const DeviceTensor& x, const std::string& p) {
  const int64_t heads = c.attn_heads.back(), inner = heads * c.attn_dim_head.back();
  DeviceTensor normed = L.layer_norm(LayerRecorder::tokens(x), p + "norm", 1e-5f);
  normed.shape = x.shape;
  const DeviceTensor qkv = conv(L, normed, p + "to_qkv");
  if (qkv.channels() != 3 * inner)
    fail(p + "to_qkv gives " + std::to_string(qkv.channels()) + " channels, not 3 x " + std::to_string(heads) + " heads x " +
         std::to_string(c.attn_dim_head.back()));
  DeviceTensor o = L.attention_qkv(LayerRecorder::tokens(qkv), u32(heads));
  o.shape = {x.batch(), inner, x.shape[2], x.shape[3]};
  return L.add(conv(L, o, p + "to_out"), x);
}

}  // namespace

void check_xunet_gpu(const XUnetConfig& c, const std::string& source) {
  if (c.weight_standardize)
    throw scene::InputError(source, "hparams.backbone.params.backbone_2d_params.unet2d_params.weight_standardize",
                            "weight-standardised convolutions are not implemented on the GPU (the release has none)");
}

void add_xunet_gpu_tensors(const GsmWeights& w, std::map<std::string, CpuTensor>& out, const std::string& prefix) {
  for (const auto& [name, t] : w.tensors) {
    if (!starts_with(name, prefix)) continue;
    const std::string rel = name.substr(prefix.size());
    if (t.rank() == 5 && ends_with(name, ".weight")) {
      if (t.dim(2) != 1)
        throw std::invalid_argument("x-unet gpu: " + name + " " + t.shape_text() + " has a frame kernel other than 1");
      const CpuTensor squeezed({t.dim(0), t.dim(1), t.dim(3), t.dim(4)}, t.data);
      const std::string m = name.substr(0, name.size() - std::string(".weight").size());
      out.insert_or_assign(name, squeezed);
      if (is_upsample_weight(rel)) {
        // (in, out, 1, kh, kw) -> conv_transpose2d's packing.
        std::vector<float> packed = kernels::nn::pack_conv_transpose2d_weights(t.data, u32(t.dim(0)), u32(t.dim(1)), u32(t.dim(3)), u32(t.dim(4)));
        const auto n = static_cast<int64_t>(packed.size());
        out.insert_or_assign(m + ".transposed_weight", CpuTensor({n}, std::move(packed)));
      } else if (is_downsample_weight(rel)) {
        // w1x1[o, c * 4 + dy * 2 + dx] -> w2x2[o, c, dy, dx]: the same index order, so the same data.
        if (t.dim(1) % 4 != 0 || t.dim(3) != 1 || t.dim(4) != 1)
          throw std::invalid_argument("x-unet gpu: " + name + " " + t.shape_text() + " is not a space-to-depth 1x1 conv");
        out.insert_or_assign(m + ".space_to_depth_weight", CpuTensor({t.dim(0), t.dim(1) / 4, 2, 2}, t.data));
      }
    } else if (ends_with(name, ".gamma")) {
      const std::string norm = name.substr(0, name.size() - std::string("gamma").size());
      out.insert_or_assign(norm + "weight", CpuTensor({t.numel()}, t.data));
      // x-unet's LayerNorm gamma is (1, C, 1, 1, 1) (RMSNorm's (C, 1, 1, 1)); it has no bias.
      if (t.rank() == 5) out.insert_or_assign(norm + "bias", CpuTensor({t.numel()}));
    }
  }
}

DeviceTensor xunet_gpu(LayerRecorder& L, const XUnetConfig& c, const std::string& prefix, const DeviceTensor& input,
                       std::map<std::string, DeviceTensor>* trace, const std::string& tp) {
  const int S = c.stages();
  if (S < 1) fail("no stages");
  if (c.weight_standardize) fail("weight standardisation is not implemented (check_xunet_gpu)");
  if (input.shape.size() != 4 || input.channels() != c.channels)
    fail("input " + shape_text(input.shape) + " is not [V, " + std::to_string(c.channels) + ", H, W]");
  const int64_t H = input.shape[2], W = input.shape[3], f = int64_t{1} << S;
  if (H % f || W % f)
    fail("H and W must be multiples of 2^stages = " + std::to_string(f) + ", not " + std::to_string(H) + " x " + std::to_string(W));
  auto put = [&](const std::string& name, const DeviceTensor& t) {
    if (trace) (*trace)[tp + name] = t;
  };

  DeviceTensor x = conv(L, input, prefix + "init_conv");
  put("init_conv", x);
  const DeviceTensor r = x;

  std::vector<DeviceTensor> down_hiddens;
  for (int s = 0; s < S; ++s) {
    const std::string p = prefix + "downs." + std::to_string(s) + ".";
    const std::string n = "downs." + std::to_string(s) + ".";
    x = resnet_block(L, x, p + "0.");
    put(n + "0", x);
    for (int b = 0; b + 1 < c.num_blocks_per_stage[static_cast<size_t>(s)]; ++b) {
      x = resnet_block(L, x, p + "1." + std::to_string(b) + ".");
      put(n + "1." + std::to_string(b), x);
    }
    down_hiddens.push_back(x);
    x = downsample(L, x, p + "3.1");
    put(n + "3", x);
  }
  down_hiddens.erase(down_hiddens.begin());  // the finest stage's map is no skip (XUnet zips params[:-1])

  x = resnet_block(L, x, prefix + "mid.");
  put("mid", x);
  const DeviceTensor attended = mid_attention(L, c, x, prefix + "mid_attn.");
  put("mid_attn", attended);
  x = resnet_block(L, L.add(attended, x), prefix + "mid_after.");  // XUnet: mid_attn(x) + x
  put("mid_after", x);
  std::vector<DeviceTensor> up_hiddens{x};  // front = finest
  x = upsample(L, x, prefix + "mid_upsample");
  put("mid_upsample", x);

  // Up stage u mirrors down stage S - 2 - u.
  for (int u = 0; u + 1 < S; ++u) {
    const int mirrored = S - 2 - u;
    const std::string p = prefix + "ups." + std::to_string(u) + ".";
    const std::string n = "ups." + std::to_string(u) + ".";
    const DeviceTensor skip = scaled(L, down_hiddens.back(), c.skip_scale);
    down_hiddens.pop_back();
    x = resnet_block(L, L.concat(x, skip), p + "0.");
    put(n + "0", x);
    for (int b = 0; b + 1 < c.num_blocks_per_stage[static_cast<size_t>(mirrored)]; ++b) {
      x = resnet_block(L, x, p + "1." + std::to_string(b) + ".");
      put(n + "1." + std::to_string(b), x);
    }
    up_hiddens.insert(up_hiddens.begin(), x);
    x = upsample(L, x, p + "3");
    put(n + "3", x);
  }

  if (c.consolidate_upsample_fmaps) {
    // FeatureMapConsolidator: each map resized (nearest) to full size, a ResnetBlock, concatenated after x.
    for (size_t i = 0; i < up_hiddens.size(); ++i) {
      const DeviceTensor& h = up_hiddens[i];
      const DeviceTensor resized = h.shape[2] == H && h.shape[3] == W
                                       ? h
                                       : L.interpolate(h, H, W, kernels::nn::InterpolateMode::nearest, false);
      x = L.concat(x, resnet_block(L, resized, prefix + "consolidator.fmap_convs." + std::to_string(i) + "."));
    }
  }
  put("consolidator", x);

  x = resnet_block(L, L.concat(x, r), prefix + "final_conv.0.");
  return conv(L, x, prefix + "final_conv.1");
}

}  // namespace icube::nn
