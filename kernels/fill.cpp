#include "kernels/fill.h"

#include "shared/primitives_params.h"

#include <stdexcept>

namespace icube::kernels {

Iota::Iota(gpu::Context& ctx) : program_(ctx.program("primitives/iota")) {}

void Iota::record(gpu::CommandList& cmd, const gpu::Buffer& out, uint64_t n, uint32_t start, uint32_t step) {
  if (n == 0) return;
  if (n > UINT32_MAX) throw std::invalid_argument("iota: n exceeds 2^32 - 1");
  shader::IotaParams params{static_cast<uint32_t>(n), start, step, 0};
  cmd.dispatch(program_, {n}, params, {out.binding(0, n * 4)});
}

std::vector<uint32_t> iota_cpu(uint64_t n, uint32_t start, uint32_t step) {
  std::vector<uint32_t> v(n);
  for (uint64_t i = 0; i < n; ++i) v[i] = start + static_cast<uint32_t>(i) * step;
  return v;
}

}  // namespace icube::kernels
