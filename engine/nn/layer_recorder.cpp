// The layers of the GPU networks; see layer_recorder.h.
#include "nn/layer_recorder.h"

#include "kernels/nn/attention.h"
#include "kernels/nn/batch_norm.h"
#include "kernels/nn/buffer_checks.h"
#include "kernels/nn/conv2d.h"
#include "kernels/nn/conv3d.h"
#include "kernels/nn/interpolate.h"
#include "kernels/nn/elementwise.h"
#include "kernels/nn/group_norm.h"
#include "kernels/nn/layer_norm.h"
#include "kernels/nn/resample.h"
#include "kernels/nn/sparse_conv.h"

#include <stdexcept>

namespace icube::nn {

namespace {

uint32_t u32(int64_t v) { return static_cast<uint32_t>(v); }

// A tensor's spatial extent as the dense kernels take it: X, Y, Z of a volume, or tokens along x.
void extent(const DeviceTensor& x, uint32_t& sx, uint32_t& sy, uint32_t& sz) {
  if (x.shape.size() == 5) {
    sx = u32(x.shape[2]);
    sy = u32(x.shape[3]);
    sz = u32(x.shape[4]);
  } else {
    sx = u32(x.spatial());
    sy = sz = 1;
  }
}

// Only the convolutions read fp16 tensors (their operands, as R16_SFLOAT texels).
void require_f32(const DeviceTensor& x, const char* layer) {
  if (x.f16)
    throw std::logic_error(std::string("LayerRecorder: ") + layer + " of an fp16 tensor (only convolutions and linears " +
                           "read fp16 operands; run this network in fp32 or fp16-weights)");
}

// Q K^T and P V over all heads: 2 x (2 N^2 C) per batch element.
uint64_t attention_flops(int64_t batch, int64_t channels, int64_t tokens) {
  return 4ull * static_cast<uint64_t>(batch) * static_cast<uint64_t>(channels) * static_cast<uint64_t>(tokens) *
         static_cast<uint64_t>(tokens);
}

}  // namespace

LayerRecorder::LayerRecorder(gpu::Context& ctx, const ParameterStore& params, const std::string& pool_name)
    : ctx_(ctx),
      params_(params),
      pool_(ctx, pool_name),
      conv_(std::make_unique<kernels::nn::Conv3d>(ctx)),
      conv2d_(std::make_unique<kernels::nn::Conv2d>(ctx)),
      channel_affine_(std::make_unique<kernels::nn::BatchNorm>(ctx)),
      interpolate_(std::make_unique<kernels::nn::Interpolate>(ctx)),
      sparse_conv_(std::make_unique<kernels::nn::SparseConv3d>(ctx)),
      group_norm_(std::make_unique<kernels::nn::GroupNorm>(ctx)),
      layer_norm_(std::make_unique<kernels::nn::LayerNorm>(ctx)),
      elementwise_(std::make_unique<kernels::nn::Elementwise>(ctx)),
      resample_(std::make_unique<kernels::nn::Resample>(ctx)),
      attention_(std::make_unique<kernels::nn::Attention>(ctx)) {}

LayerRecorder::~LayerRecorder() = default;

gpu::CommandList& LayerRecorder::cmd() const {
  if (!cmd_) throw std::logic_error("LayerRecorder: a layer recorded outside begin() / end()");
  return *cmd_;
}

void LayerRecorder::barrier() const { cmd().barrier(gpu::deps::kComputeToCompute); }

DeviceTensor LayerRecorder::alloc(std::vector<int64_t> shape, bool f16) {
  DeviceTensor t;
  t.shape = std::move(shape);
  t.f16 = f16;
  t.buf = pool_.take(std::max<uint64_t>(t.bytes(), 4));
  return t;
}

void LayerRecorder::set_f16_conv_operands(bool on) {
  if (on) kernels::nn::require_f16_storage(ctx_, "fp16 precision", "storing the convolutions' operands as fp16");
  f16_conv_operands_ = on;
}

void LayerRecorder::set_max_binding_bytes(uint64_t bytes) {
  conv_->set_max_binding_bytes(bytes);
  conv2d_->set_max_binding_bytes(bytes);
  channel_affine_->set_max_binding_bytes(bytes);
  interpolate_->set_max_binding_bytes(bytes);
  sparse_conv_->set_max_binding_bytes(bytes);
  group_norm_->set_max_binding_bytes(bytes);
  elementwise_->set_max_binding_bytes(bytes);
  resample_->set_max_binding_bytes(bytes);
}

DeviceTensor LayerRecorder::conv(const DeviceTensor& x, const std::string& prefix) {
  const std::vector<int64_t>& ws = params_.shape(prefix + ".weight");
  std::vector<int64_t> shape = x.shape;
  shape[1] = ws[0];
  DeviceTensor y = alloc(shape);
  kernels::nn::Conv3dShape s;
  s.batch = u32(x.batch());
  s.in_channels = u32(x.channels());
  s.out_channels = u32(ws[0]);
  if (x.shape.size() == 5) {
    extent(x, s.x, s.y, s.z);
  } else {  // a linear over tokens: the tokens along z, where the register tile's runs of NN_CONV_ZRUN voxels lie
    s.x = s.y = 1;
    s.z = u32(x.spatial());
  }
  s.kernel = ParameterStore::kernel_edge(ws);
  s.f16_weights = params_.f16_matrices();
  s.f16_input = x.f16;
  const std::string bias = prefix + ".bias";
  conv_->record(cmd(), s, *x.buf, params_.buffer(prefix + ".weight"), params_.has(bias) ? &params_.buffer(bias) : nullptr, *y.buf);
  matmul_flops_ += s.flops();
  barrier();
  return y;
}

DeviceTensor LayerRecorder::conv2d(const DeviceTensor& x, const std::string& prefix, uint32_t stride, uint32_t padding) {
  require_f32(x, "conv2d");
  const std::vector<int64_t>& ws = params_.shape(prefix + ".weight");
  if (x.shape.size() != 4 || ws.size() != 4 || ws[1] != x.channels())
    throw std::logic_error("LayerRecorder: conv2d " + prefix + " of weight " + shape_text(ws) + " on " + shape_text(x.shape));
  kernels::nn::Conv2dShape s;
  s.batch = u32(x.batch());
  s.in_channels = u32(x.channels());
  s.out_channels = u32(ws[0]);
  s.height = u32(x.shape[2]);
  s.width = u32(x.shape[3]);
  s.kernel_h = u32(ws[2]);
  s.kernel_w = u32(ws[3]);
  s.stride = stride;
  s.padding = padding;
  DeviceTensor y = alloc({x.batch(), ws[0], s.out_height(), s.out_width()});
  const std::string bias = prefix + ".bias";
  conv2d_->record(cmd(), s, *x.buf, params_.buffer(prefix + ".weight"), params_.has(bias) ? &params_.buffer(bias) : nullptr,
                  *y.buf);
  barrier();
  return y;
}

DeviceTensor LayerRecorder::channel_affine(const DeviceTensor& x, const std::string& scale, const std::string& shift,
                                           kernels::nn::BatchNormActivation act) {
  require_f32(x, "channel_affine");
  DeviceTensor y = alloc(x.shape);
  channel_affine_->record(cmd(), {u32(x.batch()), u32(x.channels()), static_cast<uint64_t>(x.spatial())}, *x.buf,
                          params_.buffer(scale), params_.buffer(shift), *y.buf, act);
  barrier();
  return y;
}

DeviceTensor LayerRecorder::interpolate(const DeviceTensor& x, int64_t out_h, int64_t out_w, kernels::nn::InterpolateMode mode,
                                        bool align_corners) {
  require_f32(x, "interpolate");
  if (x.shape.size() != 4) throw std::logic_error("LayerRecorder: interpolate of " + shape_text(x.shape) + " (not [B, C, H, W])");
  DeviceTensor y = alloc({x.batch(), x.channels(), out_h, out_w});
  kernels::nn::InterpolateShape s;
  s.batch = u32(x.batch());
  s.channels = u32(x.channels());
  s.in_h = u32(x.shape[2]);
  s.in_w = u32(x.shape[3]);
  s.out_h = u32(out_h);
  s.out_w = u32(out_w);
  s.mode = mode;
  s.align_corners = align_corners;
  interpolate_->record(cmd(), s, *x.buf, *y.buf);
  barrier();
  return y;
}

DeviceTensor LayerRecorder::gelu(const DeviceTensor& x) {
  require_f32(x, "gelu");
  DeviceTensor y = alloc(x.shape);
  elementwise_->gelu(cmd(), *x.buf, x.numel(), *y.buf);
  barrier();
  return y;
}

DeviceTensor LayerRecorder::relu(const DeviceTensor& x) {
  require_f32(x, "relu");
  DeviceTensor y = alloc(x.shape);
  elementwise_->relu(cmd(), *x.buf, x.numel(), *y.buf);
  barrier();
  return y;
}

DeviceTensor LayerRecorder::sparse_conv(const DeviceTensor& x, const std::string& prefix, const gpu::Buffer& kernel_map,
                                        bool silu) {
  if (x.batch() != 1) throw std::logic_error("LayerRecorder: sparse features are [1, C, rows] (" + prefix + ")");
  const std::vector<int64_t>& ws = params_.shape(prefix + ".weight");
  DeviceTensor y = alloc({1, ws[0], x.spatial()});
  const kernels::nn::SparseConvShape s{u32(x.spatial()), u32(x.channels()), u32(ws[0]), silu, params_.f16_matrices(), x.f16};
  const std::string bias = prefix + ".bias";
  sparse_conv_->record(cmd(), s, *x.buf, kernel_map, params_.buffer(prefix + ".weight"),
                       params_.has(bias) ? &params_.buffer(bias) : nullptr, *y.buf);
  barrier();
  return y;
}

DeviceTensor LayerRecorder::group_norm(const DeviceTensor& x, const std::string& prefix, const NormOptions& o) {
  require_f32(x, "group_norm");
  DeviceTensor y = alloc(x.shape, f16_conv_operands_ && !o.fp32_output);
  kernels::nn::GroupNormShape s;
  s.batch = u32(x.batch());
  s.channels = u32(x.channels());
  s.groups = o.groups;
  s.spatial = static_cast<uint64_t>(x.spatial());
  s.eps = o.eps;
  s.silu = o.silu;
  s.modulate = o.modulation != nullptr;
  s.f16_output = y.f16;
  const DeviceTensor scratch = alloc({static_cast<int64_t>(kernels::nn::GroupNorm::scratch_bytes(s) / 4 + 1), 1});
  group_norm_->record(cmd(), s, *x.buf, params_.buffer(prefix + ".weight"), params_.buffer(prefix + ".bias"),
                      o.modulation ? o.modulation->buf.get() : nullptr, *scratch.buf, *y.buf);
  barrier();
  return y;
}

DeviceTensor LayerRecorder::layer_norm(const DeviceTensor& x, const std::string& prefix, float eps) {
  require_f32(x, "layer_norm");
  DeviceTensor y = alloc(x.shape, f16_conv_operands_);
  layer_norm_->record(cmd(), {u32(x.batch()), u32(x.channels()), static_cast<uint64_t>(x.spatial()), eps, y.f16}, *x.buf,
                      params_.buffer(prefix + ".weight"), params_.buffer(prefix + ".bias"), *y.buf);
  barrier();
  return y;
}

DeviceTensor LayerRecorder::silu(const DeviceTensor& x) {
  require_f32(x, "silu");
  DeviceTensor y = alloc(x.shape);
  elementwise_->silu(cmd(), *x.buf, x.numel(), *y.buf);
  barrier();
  return y;
}

DeviceTensor LayerRecorder::add(const DeviceTensor& a, const DeviceTensor& b) {
  if (a.numel() != b.numel()) throw std::logic_error("LayerRecorder: add of tensors of different sizes");
  require_f32(a, "add");
  require_f32(b, "add");
  DeviceTensor y = alloc(a.shape);
  elementwise_->add(cmd(), *a.buf, *b.buf, a.numel(), *y.buf);
  barrier();
  return y;
}

DeviceTensor LayerRecorder::resample(const DeviceTensor& x, bool up) {
  require_f32(x, "resample");
  uint32_t sx, sy, sz;
  extent(x, sx, sy, sz);
  const uint32_t planes = u32(x.batch() * x.channels());
  std::vector<int64_t> shape = x.shape;
  for (size_t i = 2; i < shape.size(); ++i) shape[i] = up ? shape[i] * 2 : shape[i] / 2;
  DeviceTensor y = alloc(shape);
  if (up) resample_->upsample2(cmd(), *x.buf, planes, sx, sy, sz, *y.buf);
  else resample_->avg_pool2(cmd(), *x.buf, planes, sx, sy, sz, *y.buf);
  barrier();
  return y;
}

DeviceTensor LayerRecorder::geglu(const DeviceTensor& x) {
  require_f32(x, "geglu");
  DeviceTensor y = alloc({x.batch(), x.channels() / 2, x.spatial()});
  elementwise_->geglu(cmd(), *x.buf, u32(x.batch()), u32(x.channels() / 2), static_cast<uint64_t>(x.spatial()), *y.buf);
  barrier();
  return y;
}

DeviceTensor LayerRecorder::tokens(const DeviceTensor& x) {
  DeviceTensor t = x;
  t.shape = {x.batch(), x.channels(), x.spatial()};
  return t;
}

DeviceTensor LayerRecorder::concat(const DeviceTensor& a, const DeviceTensor& b) {
  require_f32(a, "concat");
  require_f32(b, "concat");
  std::vector<int64_t> shape = a.shape;
  shape[1] = a.channels() + b.channels();
  DeviceTensor y = alloc(shape);
  gpu::CommandList& c = cmd();
  c.barrier(gpu::deps::kComputeToTransfer);
  const uint64_t S = static_cast<uint64_t>(a.spatial()), ca = static_cast<uint64_t>(a.channels()),
                 cb = static_cast<uint64_t>(b.channels());
  for (uint64_t n = 0; n < static_cast<uint64_t>(a.batch()); ++n) {
    c.copy_buffer(a.buf->binding(n * ca * S * 4, ca * S * 4), y.buf->binding(n * (ca + cb) * S * 4, ca * S * 4));
    c.copy_buffer(b.buf->binding(n * cb * S * 4, cb * S * 4), y.buf->binding((n * (ca + cb) + ca) * S * 4, cb * S * 4));
  }
  c.barrier(gpu::deps::kTransferToCompute);
  return y;
}

DeviceTensor LayerRecorder::attention(const DeviceTensor& q, const DeviceTensor& k, const DeviceTensor& v, uint32_t heads) {
  require_f32(q, "attention");
  require_f32(k, "attention");
  require_f32(v, "attention");
  DeviceTensor o = alloc(q.shape);
  attention_->record(cmd(), {u32(q.batch()), heads, u32(q.channels()) / heads, static_cast<uint64_t>(q.spatial())}, *q.buf,
                     *k.buf, *v.buf, *o.buf);
  matmul_flops_ += attention_flops(q.batch(), q.channels(), q.spatial());
  barrier();
  return o;
}

DeviceTensor LayerRecorder::attention_qkv(const DeviceTensor& qkv, uint32_t heads) {
  require_f32(qkv, "attention");
  const int64_t C = qkv.channels() / 3;
  DeviceTensor o = alloc({qkv.batch(), C, qkv.spatial()});
  attention_->record_qkv(cmd(), {u32(qkv.batch()), heads, u32(C) / heads, static_cast<uint64_t>(qkv.spatial())}, *qkv.buf,
                         *o.buf);
  matmul_flops_ += attention_flops(qkv.batch(), C, qkv.spatial());
  barrier();
  return o;
}

}  // namespace icube::nn
