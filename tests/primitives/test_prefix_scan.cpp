// GPU prefix scan (shaders/primitives/scan_tile_sums.comp + shaders/primitives/scan_tiles.comp)
// against the plain-loop CPU reference: sizes around every tile and subgroup
// edge, the 65,535·64+13 dispatch edge, 20M elements, wrap-around and in-place.
#include <doctest/doctest.h>

#include "gpu_test_context.h"
#include "kernels/prefix_scan.h"

#include <random>

using namespace icube;
using kernels::ScanKind;

namespace {

void check_scan(gpu::Context& ctx, const std::vector<uint32_t>& in, ScanKind kind, bool in_place) {
  gpu::Buffer a = gpu::upload_vector(ctx, in, "scan-in");
  gpu::Buffer b(ctx, in.size() * 4, gpu::MemoryUsage::DeviceLocal, "scan-out");
  kernels::PrefixScan scan(ctx);
  scan.run(a, in_place ? a : b, in.size(), kind);
  std::vector<uint32_t> got = gpu::download_vector<uint32_t>(ctx, in_place ? a : b, in.size());
  CHECK(test::equal_report(got, kernels::prefix_scan_cpu(in, kind), kind == ScanKind::Inclusive ? "inclusive" : "exclusive"));
}

std::vector<uint32_t> random_values(uint64_t n, uint32_t seed, uint32_t mask) {
  std::mt19937 rng(seed);
  std::vector<uint32_t> v(n);
  for (auto& x : v) x = rng() & mask;
  return v;
}

}  // namespace

TEST_SUITE("subgroup-sensitive") {
  TEST_CASE("prefix scan matches the CPU reference at edge sizes") {
    gpu::Context& ctx = test::gpu_context();
    for (uint64_t n : {uint64_t(1), uint64_t(7), uint64_t(13), uint64_t(127), uint64_t(4095), uint64_t(4096),
                       uint64_t(4097), uint64_t(4096) * 4096 + 1 /* three levels */, uint64_t(65535) * 64 + 13}) {
      CAPTURE(n);
      std::vector<uint32_t> in = random_values(n, static_cast<uint32_t>(n), 0xffff);
      check_scan(ctx, in, ScanKind::Inclusive, false);
      check_scan(ctx, in, ScanKind::Exclusive, false);
    }
  }

  TEST_CASE("prefix scan of 20M elements, in place") {
    gpu::Context& ctx = test::gpu_context();
    std::vector<uint32_t> in = random_values(20000000, 20, 0xff);
    check_scan(ctx, in, ScanKind::Inclusive, true);
    check_scan(ctx, in, ScanKind::Exclusive, true);
  }

  TEST_CASE("prefix scan wraps modulo 2^32 like uint32_t arithmetic") {
    gpu::Context& ctx = test::gpu_context();
    std::vector<uint32_t> in(100003, 0xffffffffu);
    in[5] = 0;
    in[99999] = 1;
    check_scan(ctx, in, ScanKind::Inclusive, false);
    check_scan(ctx, in, ScanKind::Exclusive, true);
    std::vector<uint32_t> zeros(4099, 0u);
    check_scan(ctx, zeros, ScanKind::Inclusive, false);
  }

  TEST_CASE("prefix scan rejects undersized buffers and scratch") {
    gpu::Context& ctx = test::gpu_context();
    kernels::PrefixScan scan(ctx);
    gpu::Buffer small(ctx, 64);
    CHECK_THROWS_AS(scan.run(small, small, 17, ScanKind::Inclusive), std::invalid_argument);
    gpu::Buffer big(ctx, 8192 * 4);
    ctx.submit_and_wait([&](gpu::CommandList& cmd) {
      CHECK_THROWS_AS(scan.record(cmd, big, big, 8192, ScanKind::Inclusive, nullptr), std::invalid_argument);
    });
    CHECK(kernels::PrefixScan::scratch_elements(4096) == 0);
    CHECK(kernels::PrefixScan::scratch_elements(4097) > 0);
  }
}
