// GPU reduction (shaders/primitives/reduce.comp) against the CPU reference: every op and
// element type, sizes off the tile/subgroup grid, and extreme values.
#include <doctest/doctest.h>

#include "gpu_test_context.h"
#include "kernels/kernel_tiles.h"
#include "kernels/reduce.h"

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>

using namespace icube;
using kernels::ElementType;
using kernels::ReduceOp;

namespace {

const uint64_t kSizes[] = {1, 13, 127, 4097, 1000003};

// What the float sum guarantees (Higham, Accuracy and Stability of Numerical Algorithms, §4.2):
// when every element passes through at most k float additions on its way to the result,
// |sum - exact| <= γ_k Σ|x| with γ_k = k·u / (1 − k·u), u = 2^-24. reduce.comp's tree: per level
// a lane adds its ceil(min(m, TILE) / sg) elements of the tile in sequence, then log2(sg)
// subgroup steps; the host repeats levels over the m = ceil(m / TILE) partials until one is left.
// The CPU reference sums in double and rounds once (u·|ref|).
double float_sum_bound(uint64_t n, uint32_t sg, double abs_sum, double ref) {
  const uint64_t tile = kernels::kTileElements;
  double k = 0.0;
  for (uint64_t m = n;; m = (m + tile - 1) / tile) {
    const uint64_t per_lane = (std::min(m, tile) + sg - 1) / sg;
    k += double(per_lane - 1) + std::log2(double(sg));
    if (m <= tile) break;
  }
  const double u = std::ldexp(1.0, -24);
  return k * u / (1.0 - k * u) * abs_sum + u * std::fabs(ref);
}

template <class T>
gpu::Buffer upload_words(gpu::Context& ctx, const std::vector<T>& v) {
  static_assert(sizeof(T) == 4);
  return gpu::upload_vector(ctx, v, "reduce-in");
}

float as_float(uint32_t w) {
  float f;
  std::memcpy(&f, &w, 4);
  return f;
}

}  // namespace

TEST_SUITE("subgroup-sensitive") {
  TEST_CASE("reduce uint32 sum/min/max") {
    gpu::Context& ctx = test::gpu_context();
    for (uint64_t n : kSizes) {
      CAPTURE(n);
      std::mt19937 rng(static_cast<uint32_t>(n));
      std::vector<uint32_t> v(n);
      for (auto& x : v) x = rng();  // full range: sums wrap
      gpu::Buffer b = upload_words(ctx, v);
      for (ReduceOp op : {ReduceOp::Sum, ReduceOp::Min, ReduceOp::Max}) {
        CAPTURE(static_cast<int>(op));
        CHECK(kernels::Reduce(ctx, op, ElementType::U32).run(b, n) == kernels::reduce_cpu_u32(v, op));
      }
    }
  }

  TEST_CASE("reduce int32 sum/min/max with INT_MIN and INT_MAX") {
    gpu::Context& ctx = test::gpu_context();
    for (uint64_t n : kSizes) {
      CAPTURE(n);
      std::mt19937 rng(static_cast<uint32_t>(n) + 1);
      std::vector<int32_t> v(n);
      for (auto& x : v) x = static_cast<int32_t>(rng());
      if (n > 2) v[n / 2] = INT_MIN, v[n - 1] = INT_MAX;
      gpu::Buffer b = upload_words(ctx, v);
      for (ReduceOp op : {ReduceOp::Sum, ReduceOp::Min, ReduceOp::Max}) {
        CAPTURE(static_cast<int>(op));
        CHECK(static_cast<int32_t>(kernels::Reduce(ctx, op, ElementType::I32).run(b, n)) == kernels::reduce_cpu_i32(v, op));
      }
    }
  }

  TEST_CASE("reduce float32 sum within tolerance, min/max exact, infinities") {
    gpu::Context& ctx = test::gpu_context();
    for (uint64_t n : kSizes) {
      CAPTURE(n);
      std::mt19937 rng(static_cast<uint32_t>(n) + 2);
      std::normal_distribution<float> dist(0.5f, 100.0f);
      std::vector<float> v(n);
      double abs_sum = 0.0;
      for (auto& x : v) x = dist(rng), abs_sum += std::fabs(static_cast<double>(x));
      gpu::Buffer b = upload_words(ctx, v);
      float sum = as_float(kernels::Reduce(ctx, ReduceOp::Sum, ElementType::F32).run(b, n));
      const double ref = kernels::reduce_cpu_f32(v, ReduceOp::Sum);
      const double bound = float_sum_bound(n, ctx.subgroup_size(), abs_sum, ref);
      CAPTURE(bound / abs_sum);
      CHECK(std::fabs(static_cast<double>(sum) - ref) <= bound);
      CHECK(as_float(kernels::Reduce(ctx, ReduceOp::Min, ElementType::F32).run(b, n)) == kernels::reduce_cpu_f32(v, ReduceOp::Min));
      CHECK(as_float(kernels::Reduce(ctx, ReduceOp::Max, ElementType::F32).run(b, n)) == kernels::reduce_cpu_f32(v, ReduceOp::Max));
    }
    std::vector<float> inf = {1.0f, -std::numeric_limits<float>::infinity(), 3.0f, std::numeric_limits<float>::max()};
    gpu::Buffer b = upload_words(ctx, inf);
    CHECK(as_float(kernels::Reduce(ctx, ReduceOp::Min, ElementType::F32).run(b, 4)) == -std::numeric_limits<float>::infinity());
    CHECK(as_float(kernels::Reduce(ctx, ReduceOp::Max, ElementType::F32).run(b, 4)) == std::numeric_limits<float>::max());
    CHECK(as_float(kernels::Reduce(ctx, ReduceOp::Sum, ElementType::F32).run(b, 4)) == -std::numeric_limits<float>::infinity());
  }

  TEST_CASE("reduce of an empty array is an error") {
    gpu::Context& ctx = test::gpu_context();
    gpu::Buffer b(ctx, 16);
    CHECK_THROWS_AS(kernels::Reduce(ctx, ReduceOp::Sum, ElementType::U32).run(b, 0), std::invalid_argument);
  }
}
