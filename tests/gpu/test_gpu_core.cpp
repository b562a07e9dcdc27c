// Tests of the Vulkan compute core: device selection, error types, the
// validation messenger, dispatch checks and folding, buffers and transfers
// (mapped and staged), push-descriptor fallback and GPU timestamps.
#include <doctest/doctest.h>

#include "kernels/fill.h"
#include "gpu/commands.h"
#include "gpu_test_context.h"
#include "shared/primitives_params.h"

#include <cmath>
#include <numeric>
#include <random>
#include <stdexcept>

using namespace icube;

namespace {

gpu::DeviceInfo fake_device(uint32_t index, const char* name, VkPhysicalDeviceType type, bool usable = true) {
  gpu::DeviceInfo d;
  d.index = index;
  d.name = name;
  d.type = type;
  d.usable = usable;
  if (!usable) d.unusable_reason = "needs Vulkan 1.3";
  return d;
}

}  // namespace

TEST_CASE("device selection prefers discrete GPUs and honours ICUBE_DEVICE") {
  std::vector<gpu::DeviceInfo> devices = {
      fake_device(0, "llvmpipe (LLVM 15.0.6, 256 bits)", VK_PHYSICAL_DEVICE_TYPE_CPU),
      fake_device(1, "Intel(R) UHD Graphics", VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU),
      fake_device(2, "NVIDIA H200", VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU),
      fake_device(3, "Old GPU", VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU, false),
  };
  CHECK(gpu::select_device(devices, "").index == 2);
  CHECK(gpu::select_device(devices, "0").index == 0);
  CHECK(gpu::select_device(devices, "LLVMPIPE").index == 0);  // case-insensitive substring
  CHECK(gpu::select_device(devices, "uhd").index == 1);
  CHECK_THROWS_WITH_AS(gpu::select_device(devices, "radeon"), doctest::Contains("matches no device"), std::runtime_error);
  CHECK_THROWS_WITH_AS(gpu::select_device(devices, "3"), doctest::Contains("needs Vulkan 1.3"), std::runtime_error);
  devices.erase(devices.begin() + 1, devices.begin() + 3);
  CHECK(gpu::select_device(devices, "").index == 0);  // lavapipe is a first-class device
  CHECK_THROWS_AS(gpu::select_device({}, ""), std::runtime_error);
}

TEST_CASE("VK_CHECK names the call and maps device loss and out-of-memory to their types") {
  auto fails = [](VkResult r) { VK_CHECK(r); };
  CHECK_NOTHROW(fails(VK_SUCCESS));
  CHECK_NOTHROW(fails(VK_INCOMPLETE));  // non-error status codes pass
  CHECK_THROWS_AS(fails(VK_ERROR_DEVICE_LOST), gpu::DeviceLostError);
  CHECK_THROWS_AS(fails(VK_ERROR_OUT_OF_DEVICE_MEMORY), gpu::OutOfMemoryError);
  CHECK_THROWS_AS(fails(VK_ERROR_OUT_OF_HOST_MEMORY), gpu::OutOfMemoryError);
  try {
    fails(VK_ERROR_INITIALIZATION_FAILED);
    FAIL("VK_CHECK did not throw");
  } catch (const gpu::VulkanError& e) {
    CHECK(e.result() == VK_ERROR_INITIALIZATION_FAILED);
    CHECK(std::string(e.what()).find("VK_ERROR_INITIALIZATION_FAILED") != std::string::npos);
    CHECK(std::string(e.what()).find("tests/gpu/test_gpu_core.cpp") != std::string::npos);
  }
}

TEST_CASE("the validation messenger reports invalid API use") {
  gpu::Context& ctx = test::gpu_context();
  REQUIRE(ctx.validation_enabled());
  int errors = 0;
  ctx.set_message_handler([&](gpu::MessageSeverity s, const std::string&) { errors += s == gpu::MessageSeverity::Error; });
  // A zero-sized buffer violates VUID-VkBufferCreateInfo-size-00912.
  VkBufferCreateInfo bci{VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
  bci.size = 0;
  bci.usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT;
  VkBuffer buffer = VK_NULL_HANDLE;
  VkResult r = vkCreateBuffer(ctx.device(), &bci, nullptr, &buffer);
  if (r == VK_SUCCESS && buffer) vkDestroyBuffer(ctx.device(), buffer, nullptr);
  test::install_failing_message_handler(ctx);
  CHECK(errors >= 1);
}

TEST_CASE("group counts fold 1-D dispatches past the device limit") {
  gpu::Context& ctx = test::gpu_context();
  gpu::Program& iota = ctx.program("primitives/iota");  // local_size_x = 64
  gpu::DeviceInfo info = ctx.info();
  SUBCASE("within the limit stays 1-D") {
    gpu::GroupCounts g = gpu::group_counts(info, iota, {64ull * 1000 + 1});
    CHECK(g.x == 1001);
    CHECK(g.y == 1);
    CHECK(g.z == 1);
  }
  SUBCASE("x folds into y with little overshoot") {
    info.max_workgroup_count[0] = 100;
    const uint64_t need = 1001;
    gpu::GroupCounts g = gpu::group_counts(info, iota, {64ull * need});
    CHECK(g.x <= 100);
    CHECK(uint64_t(g.x) * g.y >= need);
    CHECK(uint64_t(g.x) * g.y - need < g.y);
  }
  SUBCASE("x folds into y and z") {
    info.max_workgroup_count[0] = 10;
    info.max_workgroup_count[1] = 10;
    const uint64_t need = 997;
    gpu::GroupCounts g = gpu::group_counts(info, iota, {64ull * need});
    CHECK(g.x <= 10);
    CHECK(g.y <= 10);
    CHECK(uint64_t(g.x) * g.y * g.z >= need);
  }
  SUBCASE("a grid that cannot fit throws") {
    info.max_workgroup_count[0] = info.max_workgroup_count[1] = info.max_workgroup_count[2] = 4;
    CHECK_THROWS_AS(gpu::group_counts(info, iota, {64ull * 65}), std::invalid_argument);
  }
}

TEST_CASE("dispatch checks push constants and bindings against the shader") {
  gpu::Context& ctx = test::gpu_context();
  gpu::Program& iota = ctx.program("primitives/iota");
  gpu::Buffer out(ctx, 256, gpu::MemoryUsage::DeviceLocal, "dispatch-check");
  struct Wrong {
    uint32_t n;
  } wrong{1};
  shader::IotaParams ok{4, 0, 1, 0};
  ctx.submit_and_wait([&](gpu::CommandList& cmd) {
    CHECK_THROWS_WITH_AS(cmd.dispatch(iota, {4}, wrong, {out.binding()}), doctest::Contains("push constants are 4 bytes"),
                         std::logic_error);
    CHECK_THROWS_WITH_AS(cmd.dispatch(iota, {4}, ok, {out.binding(), out.binding()}),
                         doctest::Contains("2 bindings given"), std::logic_error);
    CHECK_THROWS_AS(cmd.dispatch(iota, {4}, ok, {gpu::BufferBinding{out.handle(), 4, 16}}), std::invalid_argument);
    CHECK_THROWS_AS(out.binding(200, 100), std::out_of_range);
    cmd.dispatch(iota, {4}, ok, {out.binding()});
  });
  CHECK(gpu::download_vector<uint32_t>(ctx, out, 4) == std::vector<uint32_t>{0, 1, 2, 3});
}

TEST_CASE("program cache keys on shader name and specialisation constants") {
  gpu::Context& ctx = test::gpu_context();
  gpu::SpecConstants a, b;
  a.set(0, ctx.subgroup_size() /* local_size_x */).set(1, 4096u /* TILE */);
  b.set(0, ctx.subgroup_size()).set(1, 2048u);
  CHECK(&ctx.program("primitives/scan_tiles", a) == &ctx.program("primitives/scan_tiles", a));
  CHECK(&ctx.program("primitives/scan_tiles", a) != &ctx.program("primitives/scan_tiles", b));
  CHECK(ctx.program("primitives/scan_tiles", a).local_size()[0] == ctx.subgroup_size());
  CHECK_THROWS_AS(ctx.program("primitives/scan_tiles", gpu::SpecConstants{}.set(9, 1u)), std::logic_error);
  CHECK_THROWS_WITH_AS(ctx.program("no_such_kernel"), doctest::Contains("no embedded shader"), std::runtime_error);
  if (ctx.pins_subgroup_size()) CHECK(ctx.program("primitives/scan_tiles", a).pinned_subgroup_size() == ctx.subgroup_size());
}

TEST_CASE("buffers refuse impossible sizes with a clear message") {
  gpu::Context& ctx = test::gpu_context();
  CHECK_THROWS_AS(gpu::Buffer(ctx, 0), std::invalid_argument);
  CHECK_THROWS_WITH_AS(gpu::Buffer(ctx, ctx.info().max_buffer_size + 1, gpu::MemoryUsage::DeviceLocal, "huge"),
                       doctest::Contains("buffer 'huge'"), gpu::OutOfMemoryError);
}

TEST_CASE("uploads and downloads round-trip through mapped memory and through staging") {
  gpu::ContextOptions opts = gpu::ContextOptions::from_env();
  opts.force_staging = true;
  auto staged = test::make_validated_context(opts);
  for (gpu::Context* ctx : {&test::gpu_context(), staged.get()}) {
    CAPTURE(ctx->options().force_staging);
    std::mt19937 rng(7);
    for (size_t bytes : {size_t(1), size_t(13), size_t(4096), size_t(70) << 20}) {  // 70 MiB spans two staging chunks
      CAPTURE(bytes);
      std::vector<uint8_t> data(bytes);
      for (auto& b : data) b = static_cast<uint8_t>(rng());
      gpu::Buffer buf(*ctx, bytes + 64, gpu::MemoryUsage::DeviceLocal, "roundtrip");
      CHECK((buf.mapped() == nullptr) == ctx->options().force_staging);
      gpu::upload(*ctx, buf, data.data(), bytes, 32);
      std::vector<uint8_t> back(bytes);
      gpu::download(*ctx, buf, back.data(), bytes, 32);
      CHECK(back == data);
    }
    gpu::Buffer small(*ctx, 16);
    uint32_t word = 0;
    CHECK_THROWS_AS(gpu::upload(*ctx, small, &word, 4, 16), std::out_of_range);
  }
}

TEST_CASE("kernels run the same with pooled descriptor sets as with push descriptors") {
  gpu::ContextOptions opts = gpu::ContextOptions::from_env();
  opts.disable_push_descriptors = true;
  auto ctx = test::make_validated_context(opts);
  REQUIRE_FALSE(ctx->info().push_descriptor);
  REQUIRE_FALSE(ctx->program("primitives/iota").uses_push_descriptors());
  const uint64_t n = 300000;
  gpu::Buffer a(*ctx, n * 4), b(*ctx, n * 4);
  kernels::Iota iota(*ctx);
  // More dispatches than one descriptor pool holds, to exercise pool growth.
  ctx->submit_and_wait([&](gpu::CommandList& cmd) {
    for (int i = 0; i < 300; ++i) {
      iota.record(cmd, i % 2 ? b : a, n, static_cast<uint32_t>(i), 1);
      cmd.barrier(gpu::deps::kComputeToCompute);  // consecutive writes to the same buffer (WAW)
    }
  });
  CHECK(test::equal_report(gpu::download_vector<uint32_t>(*ctx, a, n), kernels::iota_cpu(n, 298, 1), "a"));
  CHECK(test::equal_report(gpu::download_vector<uint32_t>(*ctx, b, n), kernels::iota_cpu(n, 299, 1), "b"));
}

TEST_CASE("GPU timestamps measure kernel time") {
  gpu::Context& ctx = test::gpu_context();
  gpu::GpuTimer timer(ctx, 2);
  if (!timer.supported()) {
    MESSAGE("device has no compute timestamps; skipped");
    return;
  }
  const uint64_t n = 1 << 22;
  gpu::Buffer out(ctx, n * 4);
  kernels::Iota iota(ctx);
  int t = -1;
  ctx.submit_and_wait([&](gpu::CommandList& cmd) {
    timer.reset(cmd);
    t = timer.begin(cmd, "iota");
    iota.record(cmd, out, n);
    timer.end(cmd, t);
  });
  double ms = timer.milliseconds(t);
  CHECK(timer.label(t) == "iota");
  CHECK(std::isfinite(ms));
  CHECK(ms > 0.0);
  CHECK(ms < 10000.0);
}
