// iota kernel (shaders/primitives/iota.comp) against its CPU reference, plus the
// fill/copy commands, including a dispatch folded past 65,535 workgroups.
#include <doctest/doctest.h>

#include "kernels/fill.h"
#include "gpu_test_context.h"

using namespace icube;

TEST_SUITE("subgroup-sensitive") {
  TEST_CASE("iota matches the CPU reference, folded dispatches included") {
    gpu::Context& ctx = test::gpu_context();
    kernels::Iota iota(ctx);
    struct Case {
      uint64_t n;
      uint32_t start, step;
    };
    for (Case c : {Case{1, 0, 1}, Case{13, 5, 3}, Case{127, 0xfffffff0u, 1} /* wraps */, Case{65535ull * 64 + 13, 7, 2},
                   Case{5000000, 0, 0xffffffffu}}) {
      CAPTURE(c.n);
      gpu::Buffer out(ctx, c.n * 4 + 16, gpu::MemoryUsage::DeviceLocal, "iota-out");
      ctx.submit_and_wait([&](gpu::CommandList& cmd) {
        cmd.fill_buffer(out.binding(), 0xdeadbeefu);
        cmd.barrier(gpu::deps::kTransferToCompute);  // iota overwrites the fill
        iota.record(cmd, out, c.n, c.start, c.step);
      });
      std::vector<uint32_t> got = gpu::download_vector<uint32_t>(ctx, out, c.n + 4);
      CHECK(test::equal_report(std::vector<uint32_t>(got.begin(), got.begin() + static_cast<long>(c.n)),
                               kernels::iota_cpu(c.n, c.start, c.step), "iota"));
      for (size_t i = c.n; i < c.n + 4; ++i) CHECK(got[i] == 0xdeadbeefu);  // nothing past n is written
    }
  }

  TEST_CASE("fill and copy commands") {
    gpu::Context& ctx = test::gpu_context();
    gpu::Buffer a(ctx, 1024), b(ctx, 1024);
    ctx.submit_and_wait([&](gpu::CommandList& cmd) {
      cmd.fill_buffer(a.binding(), 0x01020304u);
      cmd.fill_buffer(b.binding(), 0u);
      cmd.barrier(gpu::deps::kTransferToTransfer);  // the copy reads the fill
      cmd.copy_buffer(a.binding(16, 64), b.binding(512, 64));
    });
    auto got = gpu::download_vector<uint32_t>(ctx, b, 256);
    for (size_t i = 0; i < 256; ++i) CHECK(got[i] == (i >= 128 && i < 144 ? 0x01020304u : 0u));
    ctx.submit_and_wait([&](gpu::CommandList& cmd) {
      CHECK_THROWS_AS(cmd.fill_buffer(a.binding(2, 8), 0u), std::logic_error);
      CHECK_THROWS_AS(cmd.copy_buffer(a.binding(0, 8), b.binding(0, 16)), std::logic_error);
    });
  }
}
