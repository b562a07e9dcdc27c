#include "kernels/reduce.h"

#include "kernels/kernel_tiles.h"
#include "shared/primitives_params.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace icube::kernels {

using gpu::align_up;

using gpu::Buffer;
using gpu::CommandList;

namespace {
constexpr uint32_t kSpecOp = 2, kSpecType = 3;
constexpr uint64_t kLevelAlignElems = 64;

gpu::SpecConstants reduce_spec(const gpu::Context& ctx, ReduceOp op, ElementType type) {
  gpu::SpecConstants s = subgroup_tile_spec(ctx);
  s.set(kSpecOp, static_cast<uint32_t>(op));
  s.set(kSpecType, static_cast<uint32_t>(type));
  return s;
}
}  // namespace

Reduce::Reduce(gpu::Context& ctx, ReduceOp op, ElementType type)
    : ctx_(ctx), program_(ctx.program("primitives/reduce", reduce_spec(ctx, op, type))) {}

uint64_t Reduce::scratch_elements(uint64_t n) {
  // Partials of level 1 at 0, level 2 after them, ... down to one value.
  uint64_t total = 0;
  for (uint64_t t = tiles_for(n); t > 1; t = tiles_for(t)) total += align_up(t, kLevelAlignElems);
  return std::max<uint64_t>(total, 1);
}

void Reduce::record(CommandList& cmd, const Buffer& in, uint64_t n, const Buffer& scratch, const Buffer& result,
                    uint64_t result_offset) {
  if (n == 0) throw std::invalid_argument("reduce: empty input has no sum/min/max");
  if (n > in.size() / 4) throw std::invalid_argument("reduce: n exceeds the input buffer");
  if (scratch.size() / 4 < scratch_elements(n)) throw std::invalid_argument("reduce: scratch too small");
  const Buffer* src = &in;
  uint64_t src_offset = 0, count = n, scratch_offset = 0;
  shader::ReduceParams params{};
  while (true) {
    const uint64_t tiles = tiles_for(count);
    const bool last = tiles == 1;
    const Buffer& dst = last ? result : scratch;
    const uint64_t dst_offset = last ? result_offset : scratch_offset;
    const gpu::BufferBinding partials = dst.binding(dst_offset * 4, tiles * 4);
    for (const gpu::ElementWindow& w : gpu::storage_windows(ctx_.info(), count, 4, kTileElements)) {
      params.n = static_cast<uint32_t>(w.count);
      params.out_base = static_cast<uint32_t>(w.first / kTileElements);
      cmd.dispatch(program_, {threads_for_tiles(ctx_, tiles_for(w.count))}, params,
                   {src->binding((src_offset + w.first) * 4, w.count * 4), partials});
    }
    if (last) break;
    cmd.barrier(gpu::deps::kComputeToCompute);  // the next level reads these partials
    src = &scratch;
    src_offset = scratch_offset;
    count = tiles;
    scratch_offset += align_up(tiles, kLevelAlignElems);
  }
}

uint32_t Reduce::run(const Buffer& in, uint64_t n) {
  Buffer scratch(ctx_, scratch_elements(n) * 4, gpu::MemoryUsage::DeviceLocal, "reduce-scratch");
  Buffer result(ctx_, 16, gpu::MemoryUsage::DeviceLocal, "reduce-result");
  ctx_.submit_and_wait([&](CommandList& cmd) { record(cmd, in, n, scratch, result); });
  return gpu::download_vector<uint32_t>(ctx_, result, 1)[0];
}

template <class T>
static T reduce_plain(const std::vector<T>& v, ReduceOp op) {
  T acc = v.at(0);
  for (size_t i = 1; i < v.size(); ++i)
    acc = op == ReduceOp::Sum ? static_cast<T>(acc + v[i]) : op == ReduceOp::Min ? std::min(acc, v[i]) : std::max(acc, v[i]);
  return acc;
}

uint32_t reduce_cpu_u32(const std::vector<uint32_t>& v, ReduceOp op) { return reduce_plain(v, op); }

int32_t reduce_cpu_i32(const std::vector<int32_t>& v, ReduceOp op) {
  if (op != ReduceOp::Sum) return reduce_plain(v, op);
  uint32_t acc = 0;  // wrapping sum without signed-overflow UB
  for (int32_t x : v) acc += static_cast<uint32_t>(x);
  return static_cast<int32_t>(acc);
}

float reduce_cpu_f32(const std::vector<float>& v, ReduceOp op) {
  if (op != ReduceOp::Sum) return reduce_plain(v, op);
  double acc = 0.0;
  for (float x : v) acc += static_cast<double>(x);
  return static_cast<float>(acc);
}

}  // namespace icube::kernels
