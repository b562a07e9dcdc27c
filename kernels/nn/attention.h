// Multi-head attention on the GPU over
// channels-first tensors [batch, heads * head_dim, tokens]: the UNet's
// AttentionBlock (one qkv buffer, q / k / v its channel thirds) and the
// transformer's self-attention (three buffers). Scale 1 / sqrt(head_dim) as
// F.scaled_dot_product_attention. Two kernels (AttentionPath): one thread per
// query for CPU devices (shaders/nn/attention.comp), and for GPUs a fused
// tiled kernel with keys and values streamed through shared memory, four
// threads per query (attention_tiled.comp); both online softmax, no N x N
// matrix. One dispatch, no barrier inside; every
// tensor must fit one storage binding; head_dim <= 128; on CPU devices at
// most NN_ATTN_LOOP_BUDGET loop iterations per query (about 9,500 tokens at head_dim 96).
// CPU reference: nn::cpu::attention on [B, H, N, D] (below, attention_cpu.cpp).
// Tests: tests/nn/test_attention.cpp.
#pragma once

#include "gpu/buffer.h"
#include "gpu/commands.h"
#include "kernels/nn/cpu_tensor.h"

#include <cstdint>
#include <optional>

namespace icube::kernels::nn {

enum class AttentionPath {
  kPerQuery,  // nn/attention.comp: CPU devices (lavapipe): no shared memory
  kTiled,     // nn/attention_tiled.comp: GPUs: shared-memory key/value blocks, a quad per query
};

struct AttentionShape {
  uint32_t batch = 1, heads = 1, head_dim = 1;
  uint64_t tokens = 1;
  uint64_t channels() const { return uint64_t{heads} * head_dim; }
};

class Attention {
 public:
  explicit Attention(gpu::Context& ctx);
  // q, k, v: separate [batch, C, tokens] buffers.
  void record(gpu::CommandList& cmd, const AttentionShape& s, const gpu::Buffer& q, const gpu::Buffer& k,
              const gpu::Buffer& v, const gpu::Buffer& out);
  // qkv: one [batch, 3C, tokens] buffer (q, k, v = channels [0, C), [C, 2C), [2C, 3C)).
  void record_qkv(gpu::CommandList& cmd, const AttentionShape& s, const gpu::Buffer& qkv, const gpu::Buffer& out);
  // Loop iterations one query's invocation makes (CPU devices refuse more than NN_ATTN_LOOP_BUDGET).
  static uint64_t loop_iterations(const AttentionShape& s, AttentionPath path = AttentionPath::kPerQuery);
  // Tests and benchmarks: run on `path` (nullopt: per query in lavapipe's kernel family, tiled in the GPUs':
  // kernels/nn/kernel_family.h).
  void force_path(std::optional<AttentionPath> path) { forced_path_ = path; }
  AttentionPath path() const;
  static const char* shader_name(AttentionPath path);  // "nn/attention" or "nn/attention_tiled"

 private:
  void dispatch(gpu::CommandList& cmd, const AttentionShape& s, const gpu::Buffer& q, const gpu::Buffer& k,
                const gpu::Buffer& v, uint64_t in_elements, uint64_t q_off, uint64_t k_off, uint64_t v_off,
                uint64_t in_stride, const gpu::Buffer& out);
  gpu::Context& ctx_;
  std::optional<AttentionPath> forced_path_;
};

}  // namespace icube::kernels::nn

namespace icube::nn::cpu {

// q, k, v [B, H, N, D]: softmax(q k^T * scale) v, scale = 1/sqrt(D).
CpuTensor attention(const CpuTensor& q, const CpuTensor& k, const CpuTensor& v);

}  // namespace icube::nn::cpu
