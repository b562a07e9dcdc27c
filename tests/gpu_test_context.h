// One Vulkan context per test binary, always with the Khronos validation
// layer. Any validation warning or error inside a test case fails that test
// case (doctest ADD_FAIL_CHECK from the messenger callback); messages outside
// test cases make the binary exit non-zero.
#pragma once

#include "gpu/context.h"

#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

namespace icube::test {

// The shared context (created on first use).
gpu::Context& gpu_context();

// A further context (e.g. forced staging, no push descriptors), validated the same way.
std::unique_ptr<gpu::Context> make_validated_context(gpu::ContextOptions opts);

// (Re)installs the handler that turns validation messages into test failures.
void install_failing_message_handler(gpu::Context& ctx);

// The real-data folder: $ICUBE_TEST_DATA, else ../shared/data beside the checkout
// (ICUBE_SOURCE_DIR, so the working directory does not matter). Empty when absent: the
// caller returns early, and the test case says it skipped (a MESSAGE) or, with
// ICUBE_REQUIRE_DATA=1 (CI), fails, so a missing data set never passes silently.
std::string test_data_dir();
// test_data_dir()/rel when that file exists; else empty, with the same skip or failure.
std::string test_data_file(const std::string& rel);

// |got - want| <= atol + rtol * |want| for every element; prints the first mismatches.
bool allclose(const std::vector<float>& got, const std::vector<float>& want, double atol, double rtol,
              const char* what = "values");

// Exact comparison that reports the first mismatching indices.
template <class T>
bool equal_report(const std::vector<T>& got, const std::vector<T>& want, const char* what = "values") {
  if (got.size() != want.size()) {
    std::printf("  %s: size %zu != %zu\n", what, got.size(), want.size());
    return false;
  }
  size_t bad = 0;
  for (size_t i = 0; i < got.size(); ++i) {
    if (got[i] == want[i]) continue;
    if (bad < 8)
      std::printf("  %s mismatch at %zu: got %llu want %llu\n", what, i, static_cast<unsigned long long>(got[i]),
                  static_cast<unsigned long long>(want[i]));
    ++bad;
  }
  if (bad) std::printf("  %s: %zu of %zu differ\n", what, bad, got.size());
  return bad == 0;
}

}  // namespace icube::test
