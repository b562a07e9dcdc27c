// GPU radix sort (shaders/primitives/radix_count32.comp, primitives/radix_scatter32.comp,
// primitives/radix_count64.comp, primitives/radix_scatter64.comp) against std::stable_sort: sizes
// off every tile/subgroup edge, duplicate-heavy keys (stability), presorted
// and reversed inputs, extreme keys, partial key bits and the splatting
// rasterizer's (tile id << 32 | depth bits) keys. ctest runs this suite at
// LP_NATIVE_VECTOR_WIDTH 128, 256 and 512 (subgroup sizes 4, 8, 16).
#include <doctest/doctest.h>

#include "capped_context.h"
#include "gpu_test_context.h"
#include "kernels/radix_sort.h"

#include <algorithm>
#include <cstring>
#include <numeric>
#include <random>

using namespace icube;
using kernels::KeyWidth;

namespace {

template <class K>
void check_sort(gpu::Context& ctx, std::vector<K> keys, uint32_t key_bits = 0,
                kernels::SubgroupOps match = kernels::SubgroupOps::Auto) {
  constexpr KeyWidth width = sizeof(K) == 8 ? KeyWidth::Bits64 : KeyWidth::Bits32;
  std::vector<uint32_t> values(keys.size());
  std::iota(values.begin(), values.end(), 0u);  // original positions reveal any instability
  gpu::Buffer k = gpu::upload_vector(ctx, keys, "sort-keys");
  gpu::Buffer v = gpu::upload_vector(ctx, values, "sort-values");
  kernels::RadixSort(ctx, width, match).run(k, v, keys.size(), key_bits);
  kernels::radix_sort_cpu(keys, values, key_bits ? key_bits : sizeof(K) * 8);
  CHECK(test::equal_report(gpu::download_vector<K>(ctx, k, keys.size()), keys, "keys"));
  CHECK(test::equal_report(gpu::download_vector<uint32_t>(ctx, v, values.size()), values, "values"));
}

std::vector<uint32_t> random_keys32(uint64_t n, uint32_t seed, uint32_t modulo = 0) {
  std::mt19937 rng(seed);
  std::vector<uint32_t> k(n);
  for (auto& x : k) x = modulo ? rng() % modulo : rng();
  return k;
}

std::vector<uint64_t> splat_keys(uint64_t n, uint32_t seed, uint32_t tiles) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> depth(0.05f, 1000.0f);
  std::vector<uint64_t> k(n);
  for (auto& x : k) {
    float d = depth(rng);
    uint32_t bits;
    std::memcpy(&bits, &d, 4);
    x = (uint64_t(rng() % tiles) << 32) | bits;
  }
  return k;
}

const uint64_t kSizes[] = {1, 2, 7, 13, 127, 4095, 4096, 4097, 100003};

}  // namespace

TEST_SUITE("subgroup-sensitive") {
  TEST_CASE("radix sort 32-bit keys: random, duplicates, presorted, reversed") {
    gpu::Context& ctx = test::gpu_context();
    for (uint64_t n : kSizes) {
      CAPTURE(n);
      check_sort(ctx, random_keys32(n, static_cast<uint32_t>(n)));
      check_sort(ctx, random_keys32(n, static_cast<uint32_t>(n) + 1, 17));  // heavy ties: stability
    }
    std::vector<uint32_t> sorted(50001);
    std::iota(sorted.begin(), sorted.end(), 0u);
    check_sort(ctx, sorted);
    std::reverse(sorted.begin(), sorted.end());
    check_sort(ctx, sorted);
    check_sort(ctx, std::vector<uint32_t>(30011, 0xabcdef01u));  // all equal
  }

  // Auto picks one digit-match path per device (shuffles on lavapipe, ballots on GPUs); both
  // are run here on whatever device the tests have.
  TEST_CASE("radix sort digit matches by ballots and by shuffles give the same stable sort") {
    gpu::Context& ctx = test::gpu_context();
    for (const auto match : {kernels::SubgroupOps::Intrinsics, kernels::SubgroupOps::Shuffles}) {
      CAPTURE(static_cast<int>(match));
      if (match == kernels::SubgroupOps::Shuffles && ctx.subgroup_size() > 32) continue;
      for (uint64_t n : {uint64_t{1}, uint64_t{13}, uint64_t{4097}, uint64_t{100003}}) {
        CAPTURE(n);
        check_sort(ctx, random_keys32(n, static_cast<uint32_t>(n) + 7), 0, match);
        check_sort(ctx, random_keys32(n, static_cast<uint32_t>(n) + 8, 5), 0, match);  // heavy ties: stability
        check_sort(ctx, splat_keys(n, static_cast<uint32_t>(n) + 9, 3600), 44, match);
      }
    }
  }

  TEST_CASE("radix sort 32-bit extreme keys and partial key bits") {
    gpu::Context& ctx = test::gpu_context();
    std::vector<uint32_t> extreme = random_keys32(20011, 5);
    for (size_t i = 0; i < extreme.size(); i += 3) extreme[i] = (i % 2) ? 0xffffffffu : 0u;
    check_sort(ctx, extreme);
    // Sort by the low 12 bits only: one full and one 4-bit pass; high bits ride along.
    check_sort(ctx, random_keys32(70001, 6), 12);
    check_sort(ctx, random_keys32(70001, 7), 8);
  }

  TEST_CASE("radix sort 32-bit, 1M keys") {
    check_sort(test::gpu_context(), random_keys32(1000003, 1));
  }

  TEST_CASE("radix sort 64-bit splatting keys (tile id << 32 | depth bits)") {
    gpu::Context& ctx = test::gpu_context();
    for (uint64_t n : kSizes) {
      CAPTURE(n);
      check_sort(ctx, splat_keys(n, static_cast<uint32_t>(n), 1200));
    }
    check_sort(ctx, splat_keys(1000003, 2, 8160));             // 1920x1088 at 16x16 tiles
    check_sort(ctx, splat_keys(200003, 3, 8160), 32 + 13);     // only the bits the tile id uses
  }

  TEST_CASE("radix sort 64-bit full-range and extreme keys") {
    gpu::Context& ctx = test::gpu_context();
    std::mt19937_64 rng(64);
    std::vector<uint64_t> keys(100019);
    for (auto& k : keys) k = rng();
    for (size_t i = 0; i < keys.size(); i += 5) keys[i] = (i % 2) ? ~0ull : 0ull;
    check_sort(ctx, keys);
    for (auto& k : keys) k = rng() % 5;  // ties
    check_sort(ctx, keys);
  }

  TEST_CASE("radix sort rejects inputs it cannot hold") {
    gpu::Context& ctx = test::gpu_context();
    kernels::RadixSort sort(ctx, KeyWidth::Bits64);
    // The histogram (1 KiB per 4096-key tile) bounds one sort, not the keys' binding.
    CHECK(sort.max_elements() ==
          std::min<uint64_t>(ctx.info().max_storage_buffer_range / 1024 * 4096, uint64_t{UINT32_MAX} - 4096));
    gpu::Buffer k(ctx, 64), v(ctx, 64);
    kernels::RadixSortScratch scratch(ctx, 4, KeyWidth::Bits64);
    ctx.submit_and_wait([&](gpu::CommandList& cmd) {
      CHECK_THROWS_AS(sort.record(cmd, k, v, 8, scratch), std::invalid_argument);  // scratch too small
      kernels::RadixSortScratch narrow(ctx, 8, KeyWidth::Bits32);
      CHECK_THROWS_WITH_AS(sort.record(cmd, k, v, 8, narrow), doctest::Contains("another key width"),
                           std::invalid_argument);
      CHECK_THROWS_WITH_AS(sort.record(cmd, k, v, sort.max_elements() + 1, scratch),
                           doctest::Contains("more than one sort takes"), std::invalid_argument);
    });
    std::vector<uint32_t> a = {3, 1}, b = {0};
    CHECK_THROWS_AS(kernels::radix_sort_cpu(a, b), std::invalid_argument);
  }

  // 32 KiB bindings: 4096 64-bit keys (one tile) or 8192 32-bit keys per window; the histogram
  // of up to 32 tiles fits. Every pass counts per window and scatters window x window.
  TEST_CASE("radix sort over one storage binding: windowed keys and values, the same stable sort") {
    gpu::Context& capped = test::capped_gpu_context(32u << 10);
    kernels::RadixSort sort64(capped, KeyWidth::Bits64), sort32(capped, KeyWidth::Bits32);
    CHECK(sort64.windows(30011).size() == 8);
    CHECK(sort32.windows(100003).size() == 13);
    for (uint64_t n : {uint64_t{4095}, uint64_t{4097}, uint64_t{30011}}) {
      CAPTURE(n);
      check_sort(capped, splat_keys(n, static_cast<uint32_t>(n) + 11, 1200));
      check_sort(capped, splat_keys(n, static_cast<uint32_t>(n) + 12, 3), 32 + 2);  // heavy ties, partial bits
    }
    check_sort(capped, random_keys32(100003, 13));
    check_sort(capped, random_keys32(100003, 14, 7));  // ties: stability across windows
    // 33 tiles of histogram pass 32 KiB: refused by name before any work.
    gpu::Buffer k(capped, 8 * 135168), v(capped, 4 * 135168);
    kernels::RadixSortScratch scratch(capped, 135168, KeyWidth::Bits64);
    CHECK(sort64.max_elements() == 131072);
    capped.submit_and_wait([&](gpu::CommandList& cmd) {
      CHECK_THROWS_WITH_AS(sort64.record(cmd, k, v, 135168, scratch), doctest::Contains("sort fewer by 4096"),
                           std::invalid_argument);
    });
  }
}
