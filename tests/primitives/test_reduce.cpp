// GPU reduction (shaders/primitives/reduce.comp) against the CPU reference: every op and
// element type, sizes off the tile/subgroup grid, and extreme values.
#include <doctest/doctest.h>

#include "gpu_test_context.h"
#include "reduce.h"

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
      // fp32 accumulation over n terms: error bounded by ~n_eff * eps * sum|x|.
      CHECK(std::fabs(static_cast<double>(sum) - static_cast<double>(kernels::reduce_cpu_f32(v, ReduceOp::Sum))) <=
            1e-6 + 1e-4 * abs_sum);
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
