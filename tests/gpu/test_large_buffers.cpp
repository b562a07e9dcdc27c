// Data larger than one storage binding (maxStorageBufferRange, 128 MiB on
// lavapipe): windows, and a 300 MiB array moved and processed end to end.
#include <doctest/doctest.h>

#include "gpu_test_context.h"
#include "kernels/prefix_scan.h"
#include "kernels/reduce.h"

#include <random>

using namespace icube;

TEST_CASE("storage windows cover the range in aligned, bounded slices") {
  gpu::DeviceInfo info;
  info.max_storage_buffer_range = 128ull << 20;
  info.min_storage_buffer_offset_alignment = 256;
  for (uint64_t n : {uint64_t(1), uint64_t(33554431), uint64_t(33554432), uint64_t(78643200), uint64_t(100000007)}) {
    CAPTURE(n);
    auto windows = gpu::storage_windows(info, n, 4, 4096);
    uint64_t next = 0;
    for (const auto& w : windows) {
      CHECK(w.first == next);
      CHECK(w.count * 4 <= info.max_storage_buffer_range);
      CHECK((w.first * 4) % info.min_storage_buffer_offset_alignment == 0);
      CHECK(w.first % 4096 == 0);
      next += w.count;
    }
    CHECK(next == n);
  }
  CHECK(gpu::storage_windows(info, 0, 4).empty());
  // max_bytes caps the window; windows stay multiples of the 256-byte alignment (64 elements).
  CHECK(gpu::storage_windows(info, 1000, 4, 1, 400).size() == 16);
  info.min_storage_buffer_offset_alignment = 16;
  CHECK(gpu::storage_windows(info, 1000, 4, 1, 400).size() == 10);
}

TEST_CASE("a 300 MiB array is uploaded, reduced, scanned across bindings and downloaded") {
  // Bindings capped at lavapipe's 128 MiB, so the array spans three windows on every device
  // (NVIDIA's bindings reach 4 GiB).
  gpu::ContextOptions opts = gpu::ContextOptions::from_env();
  opts.max_storage_binding = 128ull << 20;
  auto capped = test::make_validated_context(opts);
  gpu::Context& ctx = *capped;
  const uint64_t n = (300ull << 20) / 4;  // 78,643,200 uint32
  REQUIRE(n * 4 > ctx.info().max_storage_buffer_range * 2);
  std::vector<uint32_t> host(n);
  std::mt19937 rng(300);
  for (auto& v : host) v = rng() & 0xff;
  gpu::Buffer data = gpu::upload_vector(ctx, host, "big-300MiB");

  kernels::Reduce sum(ctx, kernels::ReduceOp::Sum, kernels::ElementType::U32);
  kernels::Reduce max(ctx, kernels::ReduceOp::Max, kernels::ElementType::U32);
  CHECK(sum.run(data, n) == kernels::reduce_cpu_u32(host, kernels::ReduceOp::Sum));
  host[n - 3] = 1000;  // a maximum in the last window
  gpu::upload(ctx, data, &host[n - 3], 4, (n - 3) * 4);
  CHECK(max.run(data, n) == 1000u);

  kernels::PrefixScan scan(ctx);
  scan.run(data, data, n, kernels::ScanKind::Inclusive);  // in place
  std::vector<uint32_t> got = gpu::download_vector<uint32_t>(ctx, data, n);
  std::vector<uint32_t> want = kernels::prefix_scan_cpu(host, kernels::ScanKind::Inclusive);
  CHECK(test::equal_report(got, want, "300 MiB inclusive scan"));
}
