// Multi-head attention host module; see attention.h.
#include "kernels/nn/attention.h"

#include "gpu/context.h"
#include "kernels/nn/buffer_checks.h"
#include "kernels/nn/kernel_family.h"
#include "shared/nn_params.h"

#include <cmath>
#include <stdexcept>
#include <string>
#include <tuple>

namespace icube::kernels::nn {

uint64_t Attention::loop_iterations(const AttentionShape& s, AttentionPath path) {
  if (path == AttentionPath::kTiled) {
    // Per key block: the load loop, and per key the score and accumulation loops over 32 registers.
    constexpr uint64_t kPerBlock = NN_ATTN_TILED_KEYS * NN_ATTN_MAX_HEAD_DIM / NN_ATTN_TILED_GROUP +
                                   NN_ATTN_TILED_KEYS * (2 * NN_ATTN_MAX_HEAD_DIM / 4 + 2) + NN_ATTN_MAX_HEAD_DIM / 4;
    return gpu::div_up(s.tokens, NN_ATTN_TILED_KEYS) * kPerBlock + NN_ATTN_MAX_HEAD_DIM / 2;
  }
  const uint64_t d_blocks = gpu::div_up(uint64_t{s.head_dim}, 8);
  return gpu::div_up(s.tokens, 4) * (2 * d_blocks + 1) + 2 * d_blocks + 2;
}

const char* Attention::shader_name(AttentionPath path) {
  return path == AttentionPath::kTiled ? "nn/attention_tiled" : "nn/attention";
}

Attention::Attention(gpu::Context& ctx) : ctx_(ctx) { ctx.program(shader_name(path())); }

AttentionPath Attention::path() const {
  if (forced_path_) return *forced_path_;
  return kernel_family(ctx_.info()) == KernelFamily::kLavapipe ? AttentionPath::kPerQuery : AttentionPath::kTiled;
}

void Attention::dispatch(gpu::CommandList& cmd, const AttentionShape& s, const gpu::Buffer& q, const gpu::Buffer& k,
                         const gpu::Buffer& v, uint64_t in_elements, uint64_t q_off, uint64_t k_off, uint64_t v_off,
                         uint64_t in_stride, const gpu::Buffer& out) {
  if (s.head_dim == 0 || s.head_dim > NN_ATTN_MAX_HEAD_DIM)
    throw std::invalid_argument("attention: head_dim " + std::to_string(s.head_dim) + " (1.." +
                                std::to_string(NN_ATTN_MAX_HEAD_DIM) + ")");
  if (s.batch == 0 || s.heads == 0 || s.tokens == 0) return;
  const AttentionPath attention_path = path();
  if (ctx_.info().type == VK_PHYSICAL_DEVICE_TYPE_CPU) {
    const uint64_t iterations = loop_iterations(s, attention_path);
    if (iterations > NN_ATTN_LOOP_BUDGET)
      throw std::invalid_argument("attention: " + std::to_string(s.tokens) + " tokens at head_dim " +
                                  std::to_string(s.head_dim) + " need " + std::to_string(iterations) +
                                  " loop iterations per query, over a CPU device's budget of " +
                                  std::to_string(NN_ATTN_LOOP_BUDGET) + " (lavapipe stops a shader at 65,535)");
  }
  const uint64_t out_elements = uint64_t{s.batch} * s.channels() * s.tokens;
  for (const auto& [what, elements, buf] : {std::tuple<const char*, uint64_t, const gpu::Buffer*>{"q", in_elements, &q},
                                            {"k", in_elements, &k}, {"v", in_elements, &v},
                                            {"output", out_elements, &out}}) {
    require_one_binding(ctx_, "attention", what, elements);
    require_buffer("attention", what, elements * 4, *buf);
  }
  shader::AttentionParams pc{};
  pc.batch = s.batch;
  pc.heads = s.heads;
  pc.head_dim = s.head_dim;
  pc.tokens = static_cast<uint32_t>(s.tokens);
  pc.q_offset = static_cast<uint32_t>(q_off);
  pc.k_offset = static_cast<uint32_t>(k_off);
  pc.v_offset = static_cast<uint32_t>(v_off);
  pc.in_batch_stride = static_cast<uint32_t>(in_stride);
  pc.out_batch_stride = static_cast<uint32_t>(s.channels() * s.tokens);
  pc.scale = static_cast<float>(1.0 / std::sqrt(static_cast<double>(s.head_dim)));
  const bool tiled = attention_path == AttentionPath::kTiled;
  constexpr uint64_t kQueriesPerGroup = NN_ATTN_TILED_GROUP / 4;
  const gpu::Threads threads{tiled ? uint64_t{s.batch} * s.heads * gpu::div_up(s.tokens, kQueriesPerGroup) * NN_ATTN_TILED_GROUP
                                   : uint64_t{s.batch} * s.heads * s.tokens};
  cmd.dispatch(ctx_.program(shader_name(attention_path)), threads, pc,
               {q.binding(0, in_elements * 4), k.binding(0, in_elements * 4), v.binding(0, in_elements * 4),
                out.binding(0, out_elements * 4)});
}

void Attention::record(gpu::CommandList& cmd, const AttentionShape& s, const gpu::Buffer& q, const gpu::Buffer& k,
                       const gpu::Buffer& v, const gpu::Buffer& out) {
  const uint64_t n = uint64_t{s.batch} * s.channels() * s.tokens;
  dispatch(cmd, s, q, k, v, n, 0, 0, 0, s.channels() * s.tokens, out);
}

void Attention::record_qkv(gpu::CommandList& cmd, const AttentionShape& s, const gpu::Buffer& qkv, const gpu::Buffer& out) {
  const uint64_t per = s.channels() * s.tokens;
  dispatch(cmd, s, qkv, qkv, qkv, uint64_t{s.batch} * 3 * per, 0, per, 2 * per, 3 * per, out);
}

}  // namespace icube::kernels::nn
