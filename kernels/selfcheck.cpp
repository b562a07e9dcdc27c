#include "kernels/selfcheck.h"

#include "kernels/fill.h"
#include "kernels/prefix_scan.h"
#include "kernels/radix_sort.h"
#include "kernels/reduce.h"

#include <chrono>
#include <functional>
#include <cstring>
#include <random>

namespace icube::kernels {

namespace {

template <class T>
std::string first_mismatch(const std::vector<T>& got, const std::vector<T>& want) {
  if (got.size() != want.size()) return "size " + std::to_string(got.size()) + " != " + std::to_string(want.size());
  for (size_t i = 0; i < got.size(); ++i)
    if (got[i] != want[i])
      return "first mismatch at " + std::to_string(i) + ": got " + std::to_string(got[i]) + ", want " +
             std::to_string(want[i]);
  return "";
}

SelfCheckResult timed(const std::string& name, const std::function<std::string()>& body) {
  SelfCheckResult r;
  r.name = name;
  auto t0 = std::chrono::steady_clock::now();
  try {
    std::string err = body();
    r.passed = err.empty();
    r.detail = r.passed ? "matches the CPU reference" : err;
  } catch (const std::exception& e) {
    r.detail = e.what();
  }
  r.milliseconds = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

}  // namespace

std::vector<SelfCheckResult> run_selfcheck(gpu::Context& ctx) {
  std::vector<SelfCheckResult> out;
  std::mt19937 rng(1337);
  const uint64_t n = 1000003;  // prime: off every tile and subgroup grid

  out.push_back(timed("iota (1-D dispatch folded to 2-D)", [&] {
    const uint64_t m = 65535ull * 64 + 13;
    gpu::Buffer b(ctx, m * 4, gpu::MemoryUsage::DeviceLocal, "selfcheck-iota");
    Iota iota(ctx);
    ctx.submit_and_wait([&](gpu::CommandList& cmd) { iota.record(cmd, b, m, 7, 3); });
    return first_mismatch(gpu::download_vector<uint32_t>(ctx, b, m), iota_cpu(m, 7, 3));
  }));

  out.push_back(timed("prefix scan, inclusive + exclusive, n = 1000003", [&] {
    std::vector<uint32_t> in(n);
    for (auto& v : in) v = rng() % 1000;
    gpu::Buffer a = gpu::upload_vector(ctx, in, "selfcheck-scan-in");
    gpu::Buffer b(ctx, n * 4, gpu::MemoryUsage::DeviceLocal, "selfcheck-scan-out");
    PrefixScan scan(ctx);
    scan.run(a, b, n, ScanKind::Inclusive);
    std::string e = first_mismatch(gpu::download_vector<uint32_t>(ctx, b, n), prefix_scan_cpu(in, ScanKind::Inclusive));
    if (!e.empty()) return "inclusive: " + e;
    scan.run(a, b, n, ScanKind::Exclusive);
    e = first_mismatch(gpu::download_vector<uint32_t>(ctx, b, n), prefix_scan_cpu(in, ScanKind::Exclusive));
    return e.empty() ? e : "exclusive: " + e;
  }));

  out.push_back(timed("reduce sum/min/max uint32, n = 1000003", [&] {
    std::vector<uint32_t> in(n);
    for (auto& v : in) v = rng();
    gpu::Buffer a = gpu::upload_vector(ctx, in, "selfcheck-reduce-in");
    for (ReduceOp op : {ReduceOp::Sum, ReduceOp::Min, ReduceOp::Max}) {
      uint32_t got = Reduce(ctx, op, ElementType::U32).run(a, n);
      uint32_t want = reduce_cpu_u32(in, op);
      if (got != want)
        return "op " + std::to_string(static_cast<int>(op)) + ": got " + std::to_string(got) + ", want " + std::to_string(want);
    }
    return std::string();
  }));

  out.push_back(timed("radix sort 32-bit keys + values, n = 1000003", [&] {
    std::vector<uint32_t> keys(n), values(n);
    for (uint64_t i = 0; i < n; ++i) keys[i] = rng() % 5000, values[i] = static_cast<uint32_t>(i);  // many ties: stability
    gpu::Buffer k = gpu::upload_vector(ctx, keys, "selfcheck-keys"), v = gpu::upload_vector(ctx, values, "selfcheck-values");
    RadixSort(ctx, KeyWidth::Bits32).run(k, v, n);
    radix_sort_cpu(keys, values);
    std::string e = first_mismatch(gpu::download_vector<uint32_t>(ctx, k, n), keys);
    if (!e.empty()) return "keys: " + e;
    e = first_mismatch(gpu::download_vector<uint32_t>(ctx, v, n), values);
    return e.empty() ? e : "values: " + e;
  }));

  out.push_back(timed("radix sort 64-bit (tile | depth) keys + values, n = 1000003", [&] {
    std::vector<uint64_t> keys(n);
    std::vector<uint32_t> values(n);
    std::uniform_real_distribution<float> depth(0.1f, 500.0f);
    for (uint64_t i = 0; i < n; ++i) {
      float d = depth(rng);
      uint32_t bits;
      std::memcpy(&bits, &d, 4);
      keys[i] = (uint64_t(rng() % 4000) << 32) | bits;
      values[i] = static_cast<uint32_t>(i);
    }
    gpu::Buffer k = gpu::upload_vector(ctx, keys, "selfcheck-keys64"), v = gpu::upload_vector(ctx, values, "selfcheck-values");
    RadixSort(ctx, KeyWidth::Bits64).run(k, v, n);
    radix_sort_cpu(keys, values);
    std::string e = first_mismatch(gpu::download_vector<uint64_t>(ctx, k, n), keys);
    if (!e.empty()) return "keys: " + e;
    e = first_mismatch(gpu::download_vector<uint32_t>(ctx, v, n), values);
    return e.empty() ? e : "values: " + e;
  }));
  return out;
}

}  // namespace icube::kernels
