// doctest main for icube-tests: creates the shared validated context lazily,
// routes validation messages into test failures, and fails the run when a
// message arrives outside any test case.
#define DOCTEST_CONFIG_IMPLEMENT
#include <doctest/doctest.h>

#include "capped_context.h"
#include "gpu_test_context.h"

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <memory>
#include <string>

namespace icube::test {

namespace {
std::unique_ptr<gpu::Context> g_context;
// capped_gpu_context's contexts by cap. Destroyed in main() with the shared one: left to static destruction
// they outlived the validation layer's own state and crashed the exit after a passing run.
std::map<uint64_t, std::unique_ptr<gpu::Context>> g_capped_contexts;
bool g_in_test = false;
uint64_t g_stray_messages = 0;

struct TestCaseTracker : doctest::IReporter {
  explicit TestCaseTracker(const doctest::ContextOptions&) {}
  void report_query(const doctest::QueryData&) override {}
  void test_run_start() override {}
  void test_run_end(const doctest::TestRunStats&) override {}
  void test_case_start(const doctest::TestCaseData&) override { g_in_test = true; }
  void test_case_reenter(const doctest::TestCaseData&) override { g_in_test = true; }
  void test_case_end(const doctest::CurrentTestCaseStats&) override { g_in_test = false; }
  void test_case_exception(const doctest::TestCaseException&) override {}
  void subcase_start(const doctest::SubcaseSignature&) override {}
  void subcase_end() override {}
  void log_assert(const doctest::AssertData&) override {}
  void log_message(const doctest::MessageData&) override {}
  void test_case_skipped(const doctest::TestCaseData&) override {}
};
}  // namespace

void install_failing_message_handler(gpu::Context& ctx) {
  ctx.set_message_handler([](gpu::MessageSeverity s, const std::string& text) {
    const char* kind = s == gpu::MessageSeverity::Error ? "error" : "warning";
    if (g_in_test) {
      const std::string message = std::string("Vulkan validation ") + kind + ": " + text;
      ADD_FAIL_CHECK_AT(__FILE__, __LINE__, message);
    } else {
      ++g_stray_messages;
      std::fprintf(stderr, "Vulkan validation %s outside a test case: %s\n", kind, text.c_str());
    }
  });
}

std::unique_ptr<gpu::Context> make_validated_context(gpu::ContextOptions opts) {
  opts.validation = true;  // every test runs under the Khronos validation layer
  auto ctx = std::make_unique<gpu::Context>(opts);
  install_failing_message_handler(*ctx);
  return ctx;
}

gpu::Context& gpu_context() {
  if (!g_context) {
    g_context = make_validated_context(gpu::ContextOptions::from_env());
    std::printf("[icube-tests] device [%u] %s, subgroup size %u, validation on\n", g_context->info().index,
                g_context->info().name.c_str(), g_context->subgroup_size());
  }
  return *g_context;
}

gpu::Context& capped_gpu_context(uint64_t max_storage_binding) {
  std::unique_ptr<gpu::Context>& c = g_capped_contexts[max_storage_binding];
  if (!c) {
    gpu::ContextOptions opts = gpu::ContextOptions::from_env();
    opts.max_storage_binding = max_storage_binding;
    c = make_validated_context(opts);
  }
  return *c;
}

namespace {
bool data_required() {
  const char* env = std::getenv("ICUBE_REQUIRE_DATA");
  return env && std::string(env) == "1";
}
// A missing data set skips the calling test case with a message, or fails it under ICUBE_REQUIRE_DATA=1.
void report_missing(const std::string& what) {
  if (data_required()) {
    const std::string message = "required test data missing (ICUBE_REQUIRE_DATA=1): " + what;
    ADD_FAIL_CHECK_AT(__FILE__, __LINE__, message);
  } else {
    MESSAGE("skipped: test data missing: " << what << " (set ICUBE_TEST_DATA)");
  }
}
}  // namespace

std::string test_data_dir() {
  const char* env = std::getenv("ICUBE_TEST_DATA");
  // Resolved from the checkout, not the working directory, so ctest (run in build/tests) finds it too.
  const std::filesystem::path p = env && *env ? std::filesystem::path(env)
                                              : std::filesystem::path(ICUBE_SOURCE_DIR) / ".." / "shared" / "data";
  if (std::filesystem::is_directory(p)) return p.lexically_normal().string();
  report_missing(p.string());
  return {};
}

std::string test_data_file(const std::string& rel) {
  const std::string dir = test_data_dir();
  if (dir.empty()) return {};
  const std::string path = dir + "/" + rel;
  if (std::filesystem::exists(path)) return path;
  report_missing(path);
  return {};
}

bool allclose(const std::vector<float>& got, const std::vector<float>& want, double atol, double rtol, const char* what) {
  if (got.size() != want.size()) {
    std::printf("  %s: size %zu != %zu\n", what, got.size(), want.size());
    return false;
  }
  size_t bad = 0;
  bool all_zero = true;
  for (size_t i = 0; i < got.size(); ++i) {
    double g = got[i], w = want[i];
    all_zero = all_zero && w == 0.0;
    bool ok = (std::isnan(w) && std::isnan(g)) || std::fabs(g - w) <= atol + rtol * std::fabs(w);
    if (ok) continue;
    if (bad < 8) std::printf("  %s mismatch at %zu: got %.9g want %.9g (|d| = %.3g)\n", what, i, g, w, std::fabs(g - w));
    ++bad;
  }
  if (all_zero && !got.empty()) std::printf("  warning: %s reference is all zeros\n", what);
  if (bad) std::printf("  %s: %zu of %zu outside atol %.3g + rtol %.3g\n", what, bad, got.size(), atol, rtol);
  return bad == 0;
}

}  // namespace icube::test

DOCTEST_REGISTER_LISTENER("icube-tracker", 1, icube::test::TestCaseTracker);

int main(int argc, char** argv) {
  doctest::Context context;
  context.applyCommandLine(argc, argv);
  int rc = context.run();
  icube::test::g_capped_contexts.clear();  // destruction messages count too
  icube::test::g_context.reset();
  if (icube::test::g_stray_messages) {
    std::fprintf(stderr, "icube-tests: %llu validation message(s) outside test cases\n",
                 static_cast<unsigned long long>(icube::test::g_stray_messages));
    rc = rc ? rc : 1;
  }
  return rc;
}
