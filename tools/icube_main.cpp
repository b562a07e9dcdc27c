// icube: the InfiniCube-VK command-line tool.
//
//   icube devices     list Vulkan devices and the properties kernels depend on
//   icube selfcheck   run every primitive kernel on the selected device against its CPU reference
//   icube scene ...   read, summarise, convert, plot scenes and sample routes (tools/cmd_scene*.cpp)
//
// Environment: ICUBE_DEVICE=<index|name substring> picks the device,
// ICUBE_VALIDATION=1 turns on the Khronos validation layer, ICUBE_MAX_STORAGE_BINDING=<bytes> caps
// storage bindings (the windowed paths of a smaller device).
#include "cmd_scene.h"
#include "command_registry.h"
#include "gpu/context.h"
#include "kernels/selfcheck.h"

#include <CLI/CLI.hpp>

#include <cstdio>
#include <exception>

using namespace icube;

namespace {

int cmd_devices(bool all) {
  gpu::ContextOptions opts = gpu::ContextOptions::from_env();
  gpu::Context ctx(opts);
  std::printf("Vulkan devices (selected: [%u] %s; override with ICUBE_DEVICE=<index|name>)\n\n", ctx.info().index,
              ctx.info().name.c_str());
  for (const gpu::DeviceInfo& d : ctx.all_devices()) {
    if (!all && d.index != ctx.info().index && !d.usable) continue;
    std::printf("%s%s\n", d.index == ctx.info().index ? "* " : "  ", gpu::describe_device(d).c_str());
  }
  return 0;
}

int cmd_selfcheck() {
  gpu::Context ctx(gpu::ContextOptions::from_env());
  std::printf("selfcheck on [%u] %s (%s), subgroup size %u%s\n", ctx.info().index, ctx.info().name.c_str(),
              gpu::device_type_name(ctx.info().type), ctx.subgroup_size(),
              ctx.validation_enabled() ? ", validation on" : "");
  auto results = kernels::run_selfcheck(ctx);
  int failed = 0;
  for (const auto& r : results) {
    std::printf("  %-4s %-62s %8.1f ms  %s\n", r.passed ? "ok" : "FAIL", r.name.c_str(), r.milliseconds,
                r.detail.c_str());
    failed += r.passed ? 0 : 1;
  }
  if (ctx.message_count()) {
    std::printf("  FAIL %llu validation message(s)\n", static_cast<unsigned long long>(ctx.message_count()));
    ++failed;
  }
  std::printf("selfcheck: %zu checks, %d failed\n", results.size(), failed);
  return failed ? 1 : 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"InfiniCube-VK: unbounded driving-scene generation on Vulkan compute", "icube"};
  app.require_subcommand(1);
  app.footer("Environment: ICUBE_DEVICE=<index|name substring>, ICUBE_VALIDATION=1, ICUBE_MAX_STORAGE_BINDING=<bytes, e.g. 1M>\n"
             "(caps every storage binding below the device's, to run the windowed paths as on a smaller device),\n"
             "ICUBE_NN_KERNELS=lavapipe|gpu (the network kernels' family; default: lavapipe's on CPU devices)");

  bool all = false;
  auto* devices = app.add_subcommand("devices", "List Vulkan devices and the limits and features kernels use");
  devices->add_flag("--all", all, "Also list devices that cannot run the engine");
  auto* selfcheck =
      app.add_subcommand("selfcheck", "Dispatch every primitive kernel on the selected device and verify it on the CPU");
  tools::add_scene_commands(app);
  tools::register_all_commands(app);  // world, conditions, ... (tools/cmd_*.cpp)

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  try {
    if (*devices) return cmd_devices(all);
    if (*selfcheck) return cmd_selfcheck();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "icube: error: %s\n", e.what());
    return 1;
  }
  return 0;
}
